"""mcd's planned sweeper under the name Hydra accepts (Hydra instantiates sweepers from the ``hydra_plugins``
package only): :mod:`hydra_plugins.mcd_sweep_plan.planned_sweeper`."""

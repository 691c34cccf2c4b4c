"""Hydra's entry for :class:`mcd.lit.sweep_plan.PlannedSweeper` (``conf/hydra/sweeper/planned.yaml``;
docs/benchmark.md "Scaling study"). Hydra scans this package at start-up, so it holds the name only."""

from hydra._internal.core_plugins.basic_sweeper import BasicSweeper

from mcd.lit import sweep_plan


class PlannedSweeper(sweep_plan.PlannedSweeper, BasicSweeper):
    """:class:`mcd.lit.sweep_plan.PlannedSweeper` over Hydra's basic sweeper, under the name Hydra accepts.
    ``BasicSweeper`` is the one of this scan (Hydra's core plugins are scanned, and run again, before this
    package), so that its ``super(BasicSweeper, self)`` holds for a second sweep in one process."""

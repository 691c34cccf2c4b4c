"""Hydra's entry for :class:`mcd.lit.sweep_plan.PlannedSweeper` (``conf/hydra/sweeper/planned.yaml``;
docs/benchmark.md "Scaling study"). Hydra scans this package at start-up, so it holds the name only."""

from mcd.lit import sweep_plan


class PlannedSweeper(sweep_plan.PlannedSweeper):
    """:class:`mcd.lit.sweep_plan.PlannedSweeper`, under the name Hydra accepts."""

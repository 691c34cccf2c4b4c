"""Sampling-map health (docs/benchmark.md "Sampling-map health"): for every finished run with adaptive
sampling, whether its map is adaptive, collapsed (one count on every pixel: uniform sampling) or edge-bound
(the frame's outer ring takes far more than its share of the samples), from the test averages of its
``metrics.json`` (``map_spread``, ``map_ring_share``: :mod:`mcd.core.metrics`)."""

from __future__ import annotations

import math

from mcd.core.metrics import MAP_COLLAPSED, MAP_EDGE_BOUND, MAP_RING, map_health
from mcd.reporting.finding import Finding
from mcd.reporting.runs import Run


def checks(runs: list[Run]) -> list[Finding]:
    """One ``sampling_map_health`` finding per finished run whose record has the map's figures: verdict
    ``holds`` for an adaptive map, ``does not hold`` for a collapsed or edge-bound one (``detail["health"]``
    says which), in the runs' order."""
    found = []
    for run in runs:
        m = run.metrics or {}
        if m.get("map_spread") is None:
            continue
        spread = float(m["map_spread"])
        share = math.nan if m.get("map_ring_share") is None else float(m["map_ring_share"])
        health = map_health(spread, share)
        verdict = {"adaptive": "holds", "unknown": "cannot check"}.get(health, "does not hold")
        found.append(Finding(
            "sampling_map_health", verdict, "map", "", (run.experiment,),
            {"spread": spread, "ring share": share}, run.budget,
            detail={"health": health, "seed": run.seed, "data_profile": run.data_profile,
                    "run": run.path.name, "collapsed below": MAP_COLLAPSED,
                    "edge-bound above": MAP_EDGE_BOUND, "ring": MAP_RING}))
    return found

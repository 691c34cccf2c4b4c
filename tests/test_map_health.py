"""Sampling-map health (docs/benchmark.md "Sampling-map health"): every run with adaptive sampling records its
map's spread and outer-ring share per test frame (``frames.csv``) and on average (``metrics.json``), and
``mcd.report``'s findings flag a collapsed or an edge-bound map."""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pandas as pd
import pytest

from mcd.core.metrics import MAP_COLLAPSED, MAP_EDGE_BOUND, map_health, map_ring_share, map_spread
from mcd.reporting import map_health as report_health
from mcd.reporting.finding import Finding, render
from mcd.reporting.runs import Run, find_runs
from tests.conftest import compose_cfg, store32_overrides


def test_a_constant_map_is_collapsed_and_has_no_edge_preference():
    m = np.full((33, 47), 3.0)
    assert map_spread(m) == 0.0 and map_ring_share(m) == pytest.approx(1.0)
    assert map_health(map_spread(m), map_ring_share(m)) == "collapsed"
    m[5, 7] += 1e-6  # the shipped bundle's map: a constant up to rounding
    assert map_spread(m) < MAP_COLLAPSED


def test_a_map_on_the_ring_is_edge_bound():
    m = np.full((64, 64), 2.0)
    m[:2], m[-2:], m[:, :2], m[:, -2:] = 10.0, 10.0, 10.0, 10.0
    ring = 64 * 64 - 60 * 60
    expected = (ring * 10 / (ring * 10 + 60 * 60 * 2)) / (ring / 64 ** 2)
    assert map_ring_share(m) == pytest.approx(expected) and expected > MAP_EDGE_BOUND
    assert map_health(map_spread(m), map_ring_share(m)) == "edge-bound"


def test_an_adaptive_map_inside_the_frame_is_adaptive():
    m = np.ones((32, 32))
    m[10:20, 10:20] = 30.0
    assert map_ring_share(m) < 1 and map_health(map_spread(m), map_ring_share(m)) == "adaptive"


def test_a_map_without_samples_or_interior_is_unknown():
    assert math.isnan(map_spread(np.zeros((8, 8)))) and math.isnan(map_ring_share(np.zeros((8, 8))))
    assert math.isnan(map_ring_share(np.ones((4, 9))))
    assert map_health(math.nan, math.nan) == "unknown"
    assert map_spread(np.full((3, 5), 1e5)) == 0.0  # HDR-sized counts are plain numbers


def _run(tmp_path, spread: float, share: float) -> Run:
    return Run(tmp_path / "job", config={"experiment": "F", "budget": 4, "seed": 2},
               metrics={"experiment": "F", "budget": 4, "seed": 2, "data_profile": "small",
                        "map_spread": spread, "map_ring_share": share})


@pytest.mark.parametrize(("spread", "share", "verdict", "words"), [
    (8e-9, 1.0, "does not hold", "COLLAPSED"),
    (0.4, 3.1, "does not hold", "EDGE-BOUND"),
    (0.4, 1.2, "holds", "adaptive"),
])
def test_the_report_flags_a_collapsed_or_edge_bound_map(tmp_path, spread, share, verdict, words):
    (found,) = report_health.checks([_run(tmp_path, spread, share)])
    assert found.verdict == verdict and words in render(found)
    assert Finding.from_record(json.loads(json.dumps(found.record()))) == found  # findings.json round trip


@pytest.mark.slow
def test_a_real_run_records_its_maps_health(cbox_store, tmp_path):
    """Row F, a few real steps on the 32x32 Cornell box: each test frame's spread and ring share in
    frames.csv, their means in metrics.json, and the report's finding from them."""
    from mcd.run import train_and_test

    cfg = compose_cfg(*store32_overrides(cbox_store[1].data_dir), "data.train_crop=32", "data.val_crop=32",
                      "train.batch_size=1", "+experiment=F", "train.max_steps=2", "train.max_minutes=null",
                      "train.val_every_steps=2", "train.sample_frames=[]",
                      "trainer.enable_progress_bar=false")
    train_and_test(cfg, tmp_path / "F", {}, time.perf_counter())
    frames = pd.read_csv(tmp_path / "F" / "frames.csv")
    assert {"map_spread", "map_ring_share"} <= set(frames.columns) and len(frames) == 2
    assert frames["map_spread"].ge(0).all() and frames["map_ring_share"].gt(0).all()
    m = json.loads((tmp_path / "F" / "metrics.json").read_text())
    assert m["map_spread"] == pytest.approx(frames["map_spread"].mean())
    assert m["map_ring_share"] == pytest.approx(frames["map_ring_share"].mean())
    (found,) = report_health.checks(find_runs([tmp_path]))
    assert found.subjects == ("F",) and found.detail["health"] == map_health(m["map_spread"],
                                                                             m["map_ring_share"])
    assert found.values["spread"] == pytest.approx(m["map_spread"])

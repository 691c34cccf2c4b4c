"""``checkpoints/last.ckpt`` is the last epoch, and resuming into the same run
directory keeps the earlier training curve in ``logs/metrics.csv``."""

from __future__ import annotations

import time

import pandas as pd
import pytest
import torch

from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides
from tests.reliability.conftest import FROZEN


@pytest.fixture(scope="module")
def three_epochs(cbox_store, tmp_path_factory):
    """A finished 3-epoch run directory (on the shared store) and its config overrides."""
    overrides = [*store32_overrides(cbox_store[1].data_dir), *FROZEN]
    run = tmp_path_factory.mktemp("run")
    train_and_test(compose_cfg(*overrides, "train.epochs=3"), run, {}, time.perf_counter())
    return run, overrides


@pytest.mark.slow
def test_last_ckpt_is_the_last_epoch(three_epochs):
    run, _ = three_epochs
    last = torch.load(run / "checkpoints" / "last.ckpt", weights_only=True)
    assert last["global_step"] == 3  # after the third epoch's step (the old last.ckpt: the first, step 1)
    best = [p.name for p in (run / "checkpoints").glob("best-*.ckpt")]
    assert len(best) == 1 and torch.load(run / "checkpoints" / best[0], weights_only=True)["global_step"] == 1
    assert sorted(p.name for p in (run / "checkpoints").iterdir()) == sorted([*best, "last.ckpt"])


@pytest.mark.slow
def test_resuming_keeps_the_earlier_training_curve(three_epochs):
    run, overrides = three_epochs
    curve = run / "logs" / "metrics.csv"
    before = pd.read_csv(curve)
    assert sorted(before["epoch"].dropna().unique()) == [0, 1, 2]
    cfg = compose_cfg(*overrides, "train.epochs=5", f"ckpt_path={run / 'checkpoints' / 'last.ckpt'}")
    metrics = train_and_test(cfg, run, {}, time.perf_counter())
    assert metrics["train_steps"] == 5  # 3 restored, 2 more trained
    assert torch.load(run / "checkpoints" / "last.ckpt", weights_only=True)["global_step"] == 5
    after = pd.read_csv(curve)
    assert sorted(after["epoch"].dropna().unique()) == [0, 1, 2, 3, 4]
    pd.testing.assert_frame_equal(after.iloc[: len(before)][list(before.columns)], before)


@pytest.mark.slow
def test_a_resumed_run_names_the_code_behind_each_stretch_of_steps(cbox_store, tmp_path):
    """metrics.json ``segments`` (mcd/lit/segments.py): one per process that trained, carried in the
    checkpoint; a checkpoint without the records gives a first segment of unknown code."""
    from mcd.reporting.provenance import Provenance
    from mcd.reporting.runs import load_run
    from mcd.run import git_commit

    overrides = [*store32_overrides(cbox_store[1].data_dir), *FROZEN]
    run = tmp_path / "run"
    first = train_and_test(compose_cfg(*overrides, "train.epochs=2"), run, {}, time.perf_counter())
    commit = git_commit()["commit"]
    assert [(s["start_step"], s["end_step"], s["commit"]) for s in first["segments"]] == [(0, 2, commit)]
    assert first["segments"][0]["device"].startswith("CPU ") and first["segments"][0]["seconds"] > 0

    last = run / "checkpoints" / "last.ckpt"
    saved = torch.load(last, weights_only=True)
    assert saved["callbacks"]["TrainingSegments"]["segments"][0]["end_step"] == 2
    cfg = compose_cfg(*overrides, "train.epochs=3", f"ckpt_path={last}")
    resumed = train_and_test(cfg, run, {}, time.perf_counter())
    assert [(s["start_step"], s["end_step"]) for s in resumed["segments"]] == [(0, 2), (2, 3)]
    # read back from the checkpoint as saved (its seconds end at the save, before the run's last validation)
    assert resumed["segments"][0] == saved["callbacks"]["TrainingSegments"]["segments"][0]
    prov = Provenance.gather([], [load_run(run)], command="test")
    assert f"steps 0-2 at {commit[:7]}" in prov.resumed and f"steps 2-3 at {commit[:7]}" in prov.resumed
    assert prov.earlier_s == pytest.approx(resumed["segments"][0]["seconds"])

    del saved["callbacks"]["TrainingSegments"]  # a checkpoint from before the records
    old = tmp_path / "old.ckpt"
    torch.save(saved, old)
    cfg = compose_cfg(*overrides, "train.epochs=3", f"ckpt_path={old}")
    unknown = train_and_test(cfg, tmp_path / "from_old", {}, time.perf_counter())
    assert [(s["start_step"], s["end_step"], s["commit"]) for s in unknown["segments"]] == [
        (0, 2, None), (2, 3, commit)]

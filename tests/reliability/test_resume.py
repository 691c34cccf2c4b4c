"""Defects 3 and 4 of issue 14: ``checkpoints/last.ckpt`` is the last epoch, and resuming into the same run
directory keeps the earlier training curve in ``logs/metrics.csv``."""

from __future__ import annotations

import time

import pandas as pd
import pytest
import torch

from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides

#: Row A on the session's 32x32 store: one training step and one validation per epoch; lr 0 keeps the
#: validation scores constant, so no epoch after the first is a new best (where `last.ckpt` stayed behind).
FROZEN = ["+experiment=A", "data.train_crop=32", "data.val_crop=32", "train.batch_size=1", "train.lr=0",
          "train.lr_min=0", "train.val_every=1", "++train.val_every_steps=null", "++train.patience=null",
          "train.sample_frames=[]",
          "trainer.enable_progress_bar=false"]


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

"""After a kill and a resume, ``logs/metrics.csv`` and ``curve.csv`` repeated the
rows the killed process had logged past the checkpoint it resumed from. The resumed run now drops them when it
starts (mcd/lit/csv_log.py ``drop_rows_after``), so each step appears once."""

from __future__ import annotations

import shutil
import time

import pandas as pd
import pytest

from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides
from tests.reliability.conftest import FROZEN


@pytest.mark.slow
def test_a_run_resumed_from_an_older_checkpoint_logs_each_step_once(cbox_store, tmp_path):
    overrides = [*store32_overrides(cbox_store[1].data_dir), *FROZEN]
    run = tmp_path / "run"
    last = run / "checkpoints" / "last.ckpt"
    train_and_test(compose_cfg(*overrides, "train.epochs=1"), run, {}, time.perf_counter())
    shutil.copy(last, tmp_path / "step1.ckpt")
    cfg = compose_cfg(*overrides, "train.epochs=3", f"ckpt_path={last}")
    train_and_test(cfg, run, {}, time.perf_counter())
    whole = pd.read_csv(run / "logs" / "metrics.csv")
    assert pd.read_csv(run / "curve.csv")["step"].tolist() == [1, 2, 3]
    assert whole["step"].max() >= 2

    # killed after logging steps 2 and 3, its last checkpoint from step 1: resumed from there
    shutil.copy(tmp_path / "step1.ckpt", last)
    (run / "metrics.json").unlink()
    train_and_test(compose_cfg(*overrides, "train.epochs=3", "ckpt_path=auto"), run, {}, time.perf_counter())
    assert pd.read_csv(run / "curve.csv")["step"].tolist() == [1, 2, 3]
    again = pd.read_csv(run / "logs" / "metrics.csv")
    assert sorted(again["step"]) == sorted(whole["step"])  # the same rows as the run trained in one go
    assert list(again.columns) == list(whole.columns)

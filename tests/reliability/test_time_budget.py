"""A run stopped by ``train.max_minutes`` after a resume says so (``mcd.lit.budget.stop_reason``;
docs/reliability.md, "Campaign fixes"): Lightning's ``Timer`` restores the time the earlier process used, and
the resumed run stopped on the budget, but its ``metrics.json`` said ``interrupted`` (this process alone had
not used the budget), and the scaling report listed it so."""

from __future__ import annotations

import time

import pytest
import torch

from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides
from tests.reliability.conftest import FROZEN


@pytest.mark.slow
def test_a_resumed_run_stopped_by_its_time_budget_records_max_minutes(cbox_store, tmp_path):
    overrides = [*store32_overrides(cbox_store[1].data_dir), *FROZEN]
    run = tmp_path / "run"
    first = train_and_test(compose_cfg(*overrides, "train.epochs=20", "train.max_minutes=10"), run, {},
                           time.perf_counter())
    assert first["stop_reason"] == "epochs"
    last = run / "checkpoints" / "last.ckpt"
    used = torch.load(last, weights_only=True)["callbacks"]["Timer"]["time_elapsed"]["train"]
    assert used > 0

    # the same run resumed with a budget 2 s above what the first process used: the Timer stops it after
    # about 2 s of this process, which alone never reaches the budget
    budget = (used + 2.0) / 60
    resumed = train_and_test(compose_cfg(*overrides, "train.epochs=100000", f"train.max_minutes={budget}",
                                         f"ckpt_path={last}"), run, {}, time.perf_counter())
    assert resumed["train_steps"] > 20 and resumed["train_steps"] < 100000
    assert resumed["stop_reason"] == "max_minutes"
    assert [(s["start_step"], s["end_step"]) for s in resumed["segments"]][0] == (0, 20)

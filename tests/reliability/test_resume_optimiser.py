"""Campaign 10, part 1 (docs/reliability.md, "Campaign fixes"): an interrupted run is not resumed with other
optimiser settings.

A run killed at step 40 and resumed with ``ckpt_path=auto train.lr=0.01`` trained on, exit 0, and its
``resolved_config.yaml`` said ``lr: 0.01``; but Lightning restores the optimiser's and the schedule's state
from the checkpoint (the final ``last.ckpt`` held ``base_lrs`` 0.001), so the rest trained at a mix of the two
rates and the record named neither. Now ``job.json`` records ``train.lr``, ``train.lr_min`` and
``train.weight_decay`` beside the job's identity, and such a resume is refused naming them before anything
is rendered; the same settings resume as before.
"""

from __future__ import annotations

import json
import time

import pytest

from mcd.run import train_and_test
from tests.conftest import compose_cfg


@pytest.mark.slow
def test_a_resume_with_another_learning_rate_is_refused_naming_it(own_interrupted):
    run, overrides, _ = own_interrupted
    last = run / "checkpoints" / "last.ckpt"
    before = last.read_bytes()

    other = compose_cfg(*overrides, "train.epochs=2", "train.lr=0.01", "ckpt_path=auto")
    with pytest.raises(FileExistsError, match=rf"{run} holds an interrupted run trained with other optimiser "
                                              r"settings \(train\.lr: 0\.0 there, 0\.01 here\)"):
        train_and_test(other, run, {"data": "tiny"}, time.perf_counter())
    assert last.read_bytes() == before and not (run / "metrics.json").exists()

    train_and_test(compose_cfg(*overrides, "train.epochs=2", "ckpt_path=auto"), run, {"data": "tiny"},
                   time.perf_counter())
    assert json.loads((run / "metrics.json").read_text())["train_steps"] == 2
    assert json.loads((run / "job.json").read_text())["optimiser"]["train.lr"] == 0.0  # FROZEN trains at lr 0

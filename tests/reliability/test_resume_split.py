"""Campaign 10, part 1 (docs/reliability.md, "Campaign fixes"): a run is not resumed, or skipped as
finished, under another split of its frames.

``data.test_fraction``, ``data.val_clips`` and ``data.clip_len`` split each sequence (``mcd.data.splits``),
and the job's identity held none of them. A 20-frame run killed at step 40 (test frames 0-3, training frames
9-19) and resumed with ``ckpt_path=auto data.test_fraction=0.5`` trained to its end, exit 0, and was tested
on frames 0-9, frame 9 among those it had trained on (high: a silent wrong result, test frames seen in
training); the default split rerun into that finished directory was then skipped ("skip: ... already holds a
complete metrics.json"), its scores those of the other split. Now ``job.json`` records the split, and both are
refused naming the keys; the same split resumes and is skipped as before.
"""

from __future__ import annotations

import time

import pytest

from mcd.lit.run_record import check_same_job
from mcd.run import train_and_test
from tests.conftest import compose_cfg
from tests.reliability.conftest import CHOICES


@pytest.mark.slow
def test_another_split_is_neither_resumed_nor_skipped_as_finished(own_interrupted):
    run, overrides, _ = own_interrupted
    last = run / "checkpoints" / "last.ckpt"
    before = last.read_bytes()

    other = compose_cfg(*overrides, "train.epochs=2", "data.test_fraction=0.1", "ckpt_path=auto")
    with pytest.raises(FileExistsError, match=rf"{run} holds an interrupted run of another split of the "
                                              r"frames \(data\.test_fraction: 0\.2 there, 0\.1 here\)"):
        train_and_test(other, run, CHOICES, time.perf_counter())
    assert last.read_bytes() == before and not (run / "metrics.json").exists()

    same = compose_cfg(*overrides, "train.epochs=2", "ckpt_path=auto")
    train_and_test(same, run, CHOICES, time.perf_counter())  # the same split resumes to its end
    check_same_job(run / "metrics.json", same, CHOICES)  # and a rerun of it is skipped
    with pytest.raises(FileExistsError, match=r"holds a finished run of another split of the frames "
                                              r"\(data\.clip_len: 5 there, 4 here\)"):
        check_same_job(run / "metrics.json", compose_cfg(*overrides, "data.clip_len=4"), CHOICES)

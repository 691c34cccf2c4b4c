"""Campaign 12, part 1 (docs/reliability.md, "Campaign fixes"): a resume under other training settings is
refused before anything is rendered.

An interrupted run (``last.ckpt``, no ``metrics.json``) resumed with ``ckpt_path=auto data.train_crop=32
loss.w_t=0 train.batch_size=2`` trained its last steps under those values, exit 0, and its
``resolved_config.yaml`` named them alone (medium: a wrong record, as campaign 10's ``train.lr``). Now
``job.json`` and every checkpoint record the training settings (``mcd.lit.run_record.training_settings``:
``train.*`` but the budget, ``loss.*``, ``method.*`` but what acts outside training, the crop and the
augmentations), and such a resume is refused naming each key with both values; the budget may still change.
"""

from __future__ import annotations

import time

import pytest

from mcd.run import train_and_test
from tests.conftest import compose_cfg

CHOICES = {"data": "tiny"}


@pytest.mark.slow
def test_a_resume_under_other_training_settings_is_refused_naming_the_keys(own_interrupted):
    run, overrides, store = own_interrupted  # row A killed after its checkpoint
    last = run / "checkpoints" / "last.ckpt"
    before, config = last.read_bytes(), (run / "resolved_config.yaml").read_bytes()

    for change, message in (("data.train_crop=24", r"data\.train_crop: 32 there, 24 here"),
                            ("loss.w_t=0", r"loss\.w_t: 0\.2 there, 0 here"),
                            ("train.batch_size=2", r"train\.batch_size: 1 there, 2 here"),
                            ("data.augment.flips=true", r"data\.augment\.flips: False there, True here"),
                            ("data.val_crop=24", r"data\.val_crop: 32 there, 24 here")):
        other = compose_cfg(*overrides, "train.epochs=2", change, "ckpt_path=auto")
        with pytest.raises(FileExistsError, match=rf"{run} holds an interrupted run trained with other "
                                                  rf"training settings \({message}\)"):
            train_and_test(other, run, CHOICES, time.perf_counter())
    assert last.read_bytes() == before and (run / "resolved_config.yaml").read_bytes() == config

    (run / "job.json").unlink()  # the checkpoint holds them too
    with pytest.raises(FileExistsError, match=rf"{last} holds steps trained with other training settings"):
        train_and_test(compose_cfg(*overrides, "train.epochs=2", "loss.w_t=0", "ckpt_path=auto"), run,
                       CHOICES, time.perf_counter())
    train_and_test(compose_cfg(*overrides, "train.epochs=2", "train.patience=3", "ckpt_path=auto"), run,
                   CHOICES, time.perf_counter())  # another budget resumes to its end
    assert (run / "metrics.json").is_file()

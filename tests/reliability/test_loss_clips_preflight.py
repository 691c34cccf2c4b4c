"""Campaign 11, part 1 (docs/reliability.md, "Campaign fixes"): a loss the clips cannot feed is named before
anything is rendered.

``mcd.run +experiment=unet data.clip_len=1`` (the paper's loss, ``L_t`` on the last two outputs) checked or
rendered the store, then failed at the first training step ("L_t needs clips of at least 2 frames"), exit 1
(high by the campaigns' rule: a crash after work a check could have caught). ``mcd.run`` now builds the loss
before the store and names ``data.clip_len`` and ``loss.w_t`` where the loss's ``frames_needed`` exceeds the
clips; ``loss.w_t=0`` trains on one-frame clips.
"""

from __future__ import annotations

import time

import pytest

from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides


@pytest.mark.slow
def test_one_frame_clips_with_the_temporal_loss_are_refused_before_rendering(tmp_path):
    overrides = [*store32_overrides(tmp_path / "data"), "+experiment=unet", "capacity=cpu",
                 "train.max_steps=1", "data.clip_len=1", "trainer.enable_progress_bar=false"]
    with pytest.raises(ValueError, match=r"data\.clip_len=1: the loss reads the last 2 outputs of each clip "
                                         r"\(L_t, loss\.w_t=0\.2\); raise data\.clip_len to 2 or set "
                                         r"loss\.w_t=0"):
        train_and_test(compose_cfg(*overrides), tmp_path / "run", {"data": "tiny"}, time.perf_counter())
    assert not (tmp_path / "data").exists()  # nothing rendered
    metrics = train_and_test(compose_cfg(*overrides, "loss.w_t=0"), tmp_path / "run0", {"data": "tiny"},
                             time.perf_counter())
    assert metrics["train_steps"] == 1

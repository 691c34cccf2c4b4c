"""A profile whose sequences are too short for its test frames, validation clips and one training clip is
refused before anything is rendered (``mcd.config.preflight.check_split``; docs/reliability.md, "Campaign
fixes"): ``data=medium`` with the 12-frame overrides of ``store32_overrides`` rendered all four of the
profile's scenes, then failed in the datamodule with the same message."""

from __future__ import annotations

import json

import pytest

from tests.conftest import mcd_run, store32_overrides


@pytest.mark.slow
def test_a_sequence_too_short_to_split_is_refused_before_rendering(tmp_path):
    data = tmp_path / "data"
    overrides = [o if o != "data=tiny" else "data=medium" for o in store32_overrides(data)]
    run = tmp_path / "run"
    proc = mcd_run("+experiment=unet", *overrides, "train.max_steps=2", f"hydra.run.dir={run}")
    assert proc.returncode != 0
    error = json.loads((run / "error.json").read_text())["error"]
    assert "a 12-frame sequence leaves 10 frames after the 2 test frames" in error
    assert "data.val_clips" in error and "data.frames_per_segment" in error
    assert not data.exists()  # nothing rendered

    # the same sequences with one validation clip split and train as before
    ok = mcd_run("+experiment=unet", *overrides, "data.val_clips=1", "data.transfer_scenes=[]",
                 "train.max_steps=1", "trainer.enable_progress_bar=false", "train.sample_frames=[]",
                 f"hydra.run.dir={tmp_path / 'ok'}")
    assert ok.returncode == 0, ok.stderr[-3000:]

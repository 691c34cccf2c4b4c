"""Campaign 9, part 2 (notes/reliability_campaigns.md): ``mcd-denoise`` resumed with a checkpoint whose
weights are the same but whose configuration is not (a bundle's JSON with another ``data.exposure_target``,
which sets the network's input exposure). The settings a resume compares held the weights' SHA-256 but not
the configuration the model is built and fed with, so the rerun kept every frame the other configuration
made ("3 finished before, kept"), and its outputs differed from a clean run's. Now the settings hold the
configuration's SHA-256 (``mcd.denoise.resume.config_digest``): the frames are denoised again, and equal a
clean run's. ``mcd-denoise`` runs for real on the bundled U-Net."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from mcd.data.exr import read_exr
from mcd.denoise.cli import run
from mcd.denoise.weights import BUNDLED_DIR
from tests.reliability.denoise_helpers import write_frames


@pytest.mark.slow
def test_a_checkpoint_of_another_configuration_denoises_every_frame_again(tmp_path):
    frames = tmp_path / "in"
    write_frames(frames, n=2, size=(32, 32))
    for ext in (".pt", ".json"):
        shutil.copy(BUNDLED_DIR / f"unet-cpu-small{ext}", tmp_path / f"u{ext}")
    given = [str(frames), "--checkpoint", str(tmp_path / "u.pt"), "--no-progress"]
    run([*given, "-o", str(tmp_path / "out")])
    meta = json.loads((tmp_path / "u.json").read_text())
    meta["config"]["data"]["exposure_target"] = 0.125
    (tmp_path / "u.json").write_text(json.dumps(meta))
    again = run([*given, "-o", str(tmp_path / "out")])
    assert again["resumed"] == []
    clean = run([*given, "-o", str(tmp_path / "clean")])
    assert again["exposure"] == clean["exposure"]
    for stem in ("f0000", "f0001"):
        assert np.array_equal(read_exr(tmp_path / "out" / f"{stem}.exr"),
                              read_exr(tmp_path / "clean" / f"{stem}.exr"))

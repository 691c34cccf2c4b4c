"""``mcd-denoise --scene`` denoises what the user gets (mcd/denoise/scene.py): with ``--reference-spp`` the
networks' input exposure came from frame 0's reference render, without one from frame 0's noisy input, so
a user who denoised without scoring got other outputs than the ones that were scored. The networks' exposure
now comes from the input (or ``--exposure``) either way; the scores keep one exposure of their own, from the
reference, the same for every method."""

from __future__ import annotations

import numpy as np
import pytest

from mcd.data.exr import read_exr
from mcd.data.scenes import VENDORED_DIR
from mcd.denoise.cli import run


@pytest.mark.slow
@pytest.mark.parametrize("checkpoint", ["unet-cpu-small", "F-cpu-small"])
def test_scoring_a_scene_does_not_change_its_outputs(tmp_path, checkpoint):
    common = ["--scene", str(VENDORED_DIR / "cbox" / "scene.xml"), "--width", "32", "--height", "32",
              "--frames", "2", "--checkpoint", checkpoint, "--no-progress"]
    plain = run([*common, "-o", str(tmp_path / "plain")])
    scored = run([*common, "-o", str(tmp_path / "scored"), "--reference-spp", "16", "--reference-db", "0"])
    assert scored["exposure"] == plain["exposure"] and scored["exposure_source"] == "frame 0's input"
    assert scored["score_exposure_source"] == "frame 0's reference" and plain["score_exposure"] is None
    for f in range(2):
        a = read_exr(tmp_path / "scored" / f"cbox_{f:04d}.exr")
        b = read_exr(tmp_path / "plain" / f"cbox_{f:04d}.exr")
        assert np.array_equal(a, b), (f, float(np.abs(a - b).max()))
    assert all("psnr_output" in row for row in scored["frames"])

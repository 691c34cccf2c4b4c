"""``mcd-denoise`` on frames stored as half floats or with an alpha channel (docs/reliability.md, "Campaign
fixes"): half-float frames denoise as their float32 values do; a frame's alpha channel is not denoised and not
in the outputs (R, G, B), which is now said in a warning naming the frame (it was dropped without a word)."""

from __future__ import annotations

import OpenEXR
import pytest

from tests.reliability.denoise_helpers import write_frames
from tests.reliability.test_denoise_frames_mode import _denoise

HEADER = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}


def _rewrite(path, half: bool, alpha: bool) -> None:
    """``path`` written again with its channels as half floats, and/or with an alpha channel of 0.25."""
    import numpy as np

    with OpenEXR.File(str(path), separate_channels=True) as f:
        chans = {k: np.asarray(v.pixels, dtype=np.float32) for k, v in f.channels().items()}
    if half:
        chans = {k: v.astype(np.float16) for k, v in chans.items()}
    if alpha:
        chans["A"] = np.full_like(chans["R"], 0.25, dtype=np.float32)
    OpenEXR.File(HEADER, chans).write(str(path))


def _read(path):
    import numpy as np

    with OpenEXR.File(str(path), separate_channels=True) as f:
        return {k: np.asarray(v.pixels, dtype=np.float32) for k, v in f.channels().items()}


@pytest.mark.slow
def test_half_float_and_alpha_frames(tmp_path):
    import numpy as np

    for name, half, alpha in (("float", False, False), ("half", True, False), ("alpha", False, True)):
        frames = write_frames(tmp_path / name, n=2, seed=3)
        for p in frames:
            if half or alpha:
                _rewrite(p, half=half, alpha=alpha)
        proc = _denoise(str(tmp_path / name), "-o", str(tmp_path / f"out_{name}"), "--checkpoint",
                        "unet-cpu-small")
        assert proc.returncode == 0, proc.stderr[-3000:]
        said = "an alpha channel (A), which is not denoised and not written to the outputs" in proc.stderr
        assert said == alpha, proc.stderr[-2000:]
        if alpha:
            assert f"{frames[0]} and 1 more frame(s)" in proc.stderr
    # half-float inputs: the float32 run of the same (rounded) values gives the same outputs
    ref = tmp_path / "float_of_half"
    for p in write_frames(ref, n=2, seed=3):
        _rewrite(p, half=True, alpha=False)
        chans = {k: v.astype(np.float32) for k, v in _read(p).items()}
        OpenEXR.File(HEADER, chans).write(str(p))
    proc = _denoise(str(ref), "-o", str(tmp_path / "out_ref"), "--checkpoint", "unet-cpu-small")
    assert proc.returncode == 0, proc.stderr[-3000:]
    for f in ("f0000.exr", "f0001.exr"):
        got, want = _read(tmp_path / "out_half" / f), _read(tmp_path / "out_ref" / f)
        assert sorted(got) == ["B", "G", "R"] and all(np.isfinite(v).all() for v in got.values())
        assert max(float(np.abs(got[k] - want[k]).max()) for k in want) == 0.0
    alpha_out = _read(tmp_path / "out_alpha" / "f0000.exr")
    assert sorted(alpha_out) == ["B", "G", "R"]
    plain = _read(tmp_path / "out_float" / "f0000.exr")
    assert max(float(np.abs(alpha_out[k] - plain[k]).max()) for k in plain) == 0.0

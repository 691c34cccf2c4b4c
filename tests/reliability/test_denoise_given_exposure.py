"""Campaign 12, part 2 (notes/reliability_campaigns.md): ``mcd-denoise <frames> --exposure 1e-45`` (a positive
number, so within the flag's range) made every input black to the network, and the bundled U-Net's outputs
came out about 20 times brighter than the same frames at their own exposure, exit 0, without a word. A given
exposure more than ``EXPOSURE_SPREAD`` times off the lit frames' own is named in a warning now, with the one
they give (``FrameSequence._warn_far``); one near it is not."""

from __future__ import annotations

import logging

from mcd.denoise.cli import run
from tests.reliability.denoise_helpers import refused, write_frames

UNET = ["--checkpoint", "unet-cpu-small", "--no-progress"]


def test_an_exposure_far_from_the_frames_own_is_named_in_a_warning(tmp_path, caplog):
    frames = tmp_path / "in"
    write_frames(frames, n=2)
    with caplog.at_level(logging.WARNING, logger="mcd.denoise.frames"):
        run([str(frames), "-o", str(tmp_path / "far"), "--exposure", "1e-45", *UNET])
    assert "--exposure x1e-45 is" in caplog.text
    assert "its outputs are not what it was trained for" in caplog.text
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="mcd.denoise.frames"):
        run([str(frames), "-o", str(tmp_path / "near"), "--exposure", "0.6", *UNET])
    assert "--exposure" not in caplog.text, caplog.text


def test_an_exposure_that_would_clamp_most_of_each_frame_is_refused_before_any_frame(tmp_path, capsys):
    """``--exposure 1e12`` on frames of mean about 1 (within the flag's range): the colour clamp
    (``EXPOSURE_CLAMP``) took almost every value and every output was one constant. It is refused now, with
    exit status 2, naming the flag and the largest exposure under the clamp, and nothing is written; the
    largest exposure it names is taken."""
    frames = tmp_path / "in"
    write_frames(frames, n=2)
    out = tmp_path / "out"
    err = refused(capsys, str(frames), "-o", str(out), "--exposure", "1e12", *UNET)
    assert "--exposure 1e+12 brings the frames' mean" in err and "give an exposure below" in err, err
    assert not out.exists() or not any(out.iterdir())
    largest = float(err.split("give an exposure below ")[1].split(",")[0])
    run([str(frames), "-o", str(out), "--exposure", f"{largest / 2:g}", *UNET])
    assert sorted(p.suffix for p in out.glob("*.exr")) == [".exr", ".exr"]

"""Campaign 8 (docs/reliability.md, "Campaign 8, part 2"): ``mcd-denoise`` on a sequence whose frame 0 is far
darker than the rest (a fade from near black: frame 0 at a thousandth of frames 1-2) took the one exposure of
the sequence from frame 0 (x507), and frames 1-2 came out 2.7 times too bright, without a word; campaign 6's
fix held only for a frame 0 that is black. The frame nearest the median of every frame's exposure now gives
it, with a warning, and a steady sequence keeps frame 0's."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from mcd.data.exr import read_exr
from mcd.denoise.cli import run
from mcd.denoise.frames import read_channels, write_layers
from tests.reliability.denoise_helpers import write_frames

ARGS = ("--checkpoint", "unet-cpu-small", "--no-progress")


def _scaled(path, factor: float) -> None:
    """``path``'s colour times ``factor``, its layers as they were."""
    ch = read_channels(path)
    rgb = lambda prefix: np.stack([ch[f"{prefix}{c}"] for c in "RGB"], -1)  # noqa: E731
    write_layers(path, rgb("") * factor, {"albedo": rgb("albedo."), "depth": ch["depth.Z"][..., None],
                                          "normal": np.stack([ch[f"normal.{c}"] for c in "XYZ"], -1)})


@pytest.mark.parametrize("factor", [1e-3, 1e3])
def test_frame_0_far_off_the_rest_does_not_set_the_sequences_exposure(tmp_path, caplog, factor):
    frames, alone = tmp_path / "in", tmp_path / "alone"
    paths = write_frames(frames, n=3, seed=1)
    write_frames(alone, n=3, seed=1)
    (alone / "f0000.exr").unlink()                  # frames 1-2 alone: their own exposure
    _scaled(paths[0], factor)
    with caplog.at_level(logging.WARNING, logger="mcd.denoise.frames"):
        report = run([str(frames), "-o", str(tmp_path / "out"), *ARGS])
    run([str(alone), "-o", str(tmp_path / "out_alone"), *ARGS])
    for name in ("f0001.exr", "f0002.exr"):
        ratio = read_exr(tmp_path / "out" / name).mean() / read_exr(tmp_path / "out_alone" / name).mean()
        assert 0.95 < ratio < 1.05, f"{name}: {ratio:.3f} times the output of the frames denoised alone"
    assert f"{paths[0]}: its exposure x" in caplog.text and "nearest the median" in caplog.text
    assert report["exposure"] < 1.0


def test_a_steady_sequence_keeps_frame_0s_exposure(tmp_path, caplog):
    frames = tmp_path / "in"
    write_frames(frames, n=3, seed=1)
    _scaled(frames / "f0002.exr", 4.0)              # within the spread: no change of rule
    with caplog.at_level(logging.WARNING, logger="mcd.denoise.frames"):
        report = run([str(frames), "-o", str(tmp_path / "out"), *ARGS])
    first = run([str(frames / "f0000.exr"), "-o", str(tmp_path / "first"), *ARGS])
    assert report["exposure"] == first["exposure"] and "nearest the median" not in caplog.text

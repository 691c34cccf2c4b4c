"""One firefly in frame 0 no longer changes the whole denoised sequence (mcd/data/exposure.py
``input_exposure``, docs/denoise.md "Frames from disk"): ``mcd-denoise`` took the network's exposure from
frame 0's plain mean, so one pixel of 1e6 in a 128x128 frame 0 darkened every frame the network saw, and frame
1, whose input is the clean run's, came out at another brightness. The mean is now robust (fireflies clamped),
and a warning names the file when an outlier would have moved it."""

from __future__ import annotations

import logging
import shutil

import numpy as np

from mcd.data.exr import read_exr
from mcd.denoise.cli import run
from mcd.denoise.frames import read_channels, write_layers
from tests.reliability.denoise_helpers import write_frames


def _denoise(folder, out):
    return run([str(folder), "-o", str(out), "--checkpoint", "unet-cpu-small", "--no-progress"])


def test_one_firefly_in_frame_0_leaves_the_other_frames_as_a_clean_run_makes_them(tmp_path, caplog):
    clean = tmp_path / "clean"
    paths = write_frames(clean, n=3, size=(128, 128), seed=2)
    fire = tmp_path / "firefly"
    shutil.copytree(clean, fire)
    chans = read_channels(paths[0])
    colour = np.stack([chans[c] for c in "RGB"], -1)
    colour[40, 70] = 1e6  # one pixel of frame 0
    layers = {"albedo": np.stack([chans[f"albedo.{c}"] for c in "RGB"], -1),
              "normal": np.stack([chans[f"normal.{c}"] for c in "XYZ"], -1),
              "depth": chans["depth.Z"][..., None]}
    write_layers(fire / paths[0].name, colour, layers)

    base = _denoise(clean, tmp_path / "out_clean")
    with caplog.at_level(logging.WARNING, logger="mcd.data.exposure"):
        hit = _denoise(fire, tmp_path / "out_firefly")
    for stem in ("f0001", "f0002"):  # inputs identical to the clean run's
        a = read_exr(tmp_path / "out_firefly" / f"{stem}.exr")
        b = read_exr(tmp_path / "out_clean" / f"{stem}.exr")
        assert abs(a.mean() / b.mean() - 1) < 0.01, (stem, a.mean(), b.mean())
        assert np.abs(a - b).mean() < 0.01 * b.mean()
    assert abs(hit["exposure"] / base["exposure"] - 1) < 0.01, (hit["exposure"], base["exposure"])
    assert f"{fire / 'f0000.exr'}: 3 of 49152 values above" in caplog.text
    assert "would have moved it from x" in caplog.text

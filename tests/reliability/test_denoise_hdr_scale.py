"""``mcd-denoise`` on frames in any units (mcd/data/exposure.py ``input_exposure``, docs/reliability.md
"Campaign fixes"): the network's exposure clamped frame 0's values to 1e8 before taking their mean, so a
sequence of mean 1e9 reached the network 10 times too bright and one of mean 1e12 or 1e20 far off, and came
out wrong without a word (the outputs of the same frames scaled by 1e12 were 6.6 times too bright, by 1e20
128 times too dark). The mean is now taken in float64 without that clamp: denoising commutes with the
frames' units, and frames near float32's largest value give finite outputs."""

from __future__ import annotations

import logging

import numpy as np
import pytest

from mcd.data.exr import read_exr
from mcd.denoise.cli import run
from mcd.denoise.frames import read_channels, write_layers
from tests.reliability.denoise_helpers import write_frames


def _scaled_copy(src: list, folder, scale: float) -> None:
    folder.mkdir()
    for path in src:
        chans = read_channels(path)
        colour = np.stack([chans[c] for c in "RGB"], -1).astype(np.float64) * scale
        colour = np.minimum(colour, np.finfo(np.float32).max).astype(np.float32)
        layers = {"albedo": np.stack([chans[f"albedo.{c}"] for c in "RGB"], -1),
                  "normal": np.stack([chans[f"normal.{c}"] for c in "XYZ"], -1),
                  "depth": chans["depth.Z"][..., None]}
        write_layers(folder / path.name, colour, layers)


def _denoise(folder, out):
    return run([str(folder), "-o", str(out), "--checkpoint", "unet-cpu-small", "--no-progress"])


@pytest.mark.parametrize("scale", [1e9, 1e12, 1e20])
def test_frames_in_large_units_denoise_as_the_same_frames_in_small_ones(tmp_path, scale):
    paths = write_frames(tmp_path / "unit", n=2, size=(32, 32), seed=4)
    _scaled_copy(paths, tmp_path / "big", scale)
    base = _denoise(tmp_path / "unit", tmp_path / "out_unit")
    big = _denoise(tmp_path / "big", tmp_path / "out_big")
    assert big["exposure"] == pytest.approx(base["exposure"] / scale, rel=1e-5)
    for path in paths:
        a = read_exr(tmp_path / "out_big" / path.name).astype(np.float64) / scale
        b = read_exr(tmp_path / "out_unit" / path.name).astype(np.float64)
        assert np.abs(a - b).max() < 1e-4 * np.abs(b).max(), (path.name, a.mean(), b.mean())


def _flushing() -> bool:
    """Whether this process flushes denormal floats to zero (``torch.set_flush_denormal``)."""
    return bool(np.array([1e-39], np.float32)[0] * np.float32(1.0) == 0)


@pytest.fixture
def flush_denormal(request):
    """``torch.set_flush_denormal(request.param)`` for the test, the process's own setting restored after."""
    import torch

    before = _flushing()
    if not torch.set_flush_denormal(request.param) and request.param:
        pytest.skip("this CPU cannot flush denormals to zero")
    yield request.param
    torch.set_flush_denormal(before)


@pytest.mark.parametrize("flush_denormal", [False, True], indirect=True, ids=["denormals", "flushed"])
def test_frames_near_float32s_largest_value_give_finite_outputs(tmp_path, flush_denormal):
    """Their exposure (about 5e-39) is a float32 denormal; a process that flushes denormals (CPU training
    sets it, mcd.lit.budget) read it as 0: black inputs and NaN outputs after any test that trained."""
    assert _flushing() == flush_denormal
    paths = write_frames(tmp_path / "unit", n=2, size=(16, 24), seed=5)
    _scaled_copy(paths, tmp_path / "huge", 1e38)  # mean about 1e38, values up to float32's largest
    _denoise(tmp_path / "huge", tmp_path / "out")
    for path in paths:
        out = read_exr(tmp_path / "out" / path.name)
        assert np.isfinite(out).all() and out.mean(dtype=np.float64) > 1e37, path.name


def test_a_sequence_that_fades_in_from_black_takes_its_exposure_from_its_first_lit_frame(tmp_path, caplog):
    """Frame 0 black (a fade-in) left the exposure at 1, so frames of mean 1e5 after it came out about 13
    times too bright; the exposure now comes from the first frame that is not black."""
    paths = write_frames(tmp_path / "unit", n=3, size=(32, 32), seed=6)
    _scaled_copy(paths, tmp_path / "lit", 1e5)
    faded = tmp_path / "faded"
    _scaled_copy(paths, faded, 1e5)
    _scaled_copy(paths[:1], tmp_path / "black", 0.0)
    (tmp_path / "black" / paths[0].name).replace(faded / paths[0].name)
    lit = _denoise(tmp_path / "lit", tmp_path / "out_lit")
    with caplog.at_level(logging.INFO, logger="mcd.denoise.frames"):
        fade = _denoise(faded, tmp_path / "out_faded")
    assert "frames 0-0 are black; exposure x" in caplog.text
    assert fade["exposure"] == pytest.approx(lit["exposure"], rel=0.2)  # frame 1's mean, not frame 0's
    for path in paths[1:]:  # the same inputs as the lit run's
        a = read_exr(tmp_path / "out_faded" / path.name).astype(np.float64)
        b = read_exr(tmp_path / "out_lit" / path.name).astype(np.float64)
        assert abs(a.mean() / b.mean() - 1) < 0.05, (path.name, a.mean(), b.mean())
    assert read_exr(tmp_path / "out_faded" / paths[0].name).max() == 0

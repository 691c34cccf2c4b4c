"""The luminance/colour split of ``python tools/colour_split.py`` (notes/colour_error.md): an error put only
in a frame's brightness is found only there, one put only in its hue only there, and a pixel-sized hue error
is what colour smoothing takes away; real EXR files in a run's samples layout."""

from __future__ import annotations

import numpy as np
import pytest

from mcd.core.metrics import PSNR_CAP_DB
from mcd.data.exr import write_exr
from mcd.models.inputs import LUMA
from tools.colour_split import frame_figures, luminance, main, measure, recombine


def _reference(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    grey = rng.uniform(0.05, 3.0, (24, 20, 1))
    return (grey * np.array([0.9, 0.7, 0.5])).astype(np.float32)  # one warm albedo, HDR brightness


def test_a_brightness_error_shows_in_luminance_only():
    ref = _reference()
    brighter = ref * 1.6
    f = frame_figures(brighter, ref, 5)
    assert f["colour error only"] == PSNR_CAP_DB          # the reference's luminance, the same chromaticity
    assert f["luminance error only"] == pytest.approx(f["as saved"], abs=1e-6)
    assert f["hue off %"] == 0.0
    assert f["as saved"] < 40.0


def test_a_hue_error_shows_in_colour_only_and_smoothing_removes_a_pixel_sized_one():
    ref = _reference()
    specked = ref.copy()
    blue = np.array([0.2, 0.6, 1.4])
    specked[::6, ::5] = luminance(ref)[::6, ::5] * blue / (blue @ LUMA)  # blue specks of the same Y
    assert np.allclose(luminance(specked), luminance(ref), rtol=1e-5)
    f = frame_figures(specked, ref, 5)
    assert f["luminance error only"] == PSNR_CAP_DB
    assert f["colour error only"] == pytest.approx(f["as saved"], abs=0.05)
    assert f["hue off %"] == pytest.approx(100.0 * 4 * 4 / (24 * 20))
    assert f["colour smoothed"] > f["as saved"] + 3.0       # 1 speck in 30 pixels: averaged away


def test_the_hue_of_another_image_puts_a_hue_error_right_and_leaves_brightness_alone():
    ref = _reference()
    blue = np.array([0.2, 0.6, 1.4])
    wrong = luminance(ref) * 1.3 * blue / (blue @ LUMA)   # too bright, and blue everywhere
    grey_filter = ref * 0.5                                    # the reference's hue, half its brightness
    f = frame_figures(wrong, ref, 1, ("initial", grey_filter))
    g = frame_figures(ref * 1.3, ref, 1)
    assert f["hue from initial"] == pytest.approx(g["as saved"], abs=1e-4)  # the brightness error stays
    assert f["hue from initial"] > f["as saved"] + 3.0


def test_recombine_leaves_black_pixels_as_they_are():
    ref = _reference()
    out = ref * 1.1
    out[3, 4] = 0.0                                        # black in the output: no chromaticity to take
    ref[5, 6] = 0.0
    mixed = recombine(out, ref)
    assert np.array_equal(mixed[3, 4], out[3, 4]) and np.array_equal(mixed[5, 6], out[5, 6])
    assert np.isfinite(mixed).all()


def test_a_run_folder_is_read_per_scene_and_a_folder_without_samples_is_named(tmp_path, capsys):
    run = tmp_path / "F_run"
    for scene, scale in (("cbox", 1.0), ("room0", 2.0)):
        ref = _reference(1) * scale
        for frame in (0, 3):
            write_exr(run / "samples" / scene / f"{frame:04d}_reference.exr", ref)
            out = ref * (1.2 if scene == "cbox" else 1.0)
            write_exr(run / "samples" / scene / f"{frame:04d}_output.exr", out)
    rows = measure(run, 3, per_scene=True)
    assert [(r["scenes"], r["frames"]) for r in rows] == [("cbox", 2), ("room0", 2)]
    assert rows[0]["as saved"] < PSNR_CAP_DB and rows[1]["as saved"] == PSNR_CAP_DB
    assert measure(run, 3, per_scene=False)[0]["frames"] == 4
    main([str(run)])
    assert "| F_run | output | all | 4 |" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main([str(run), "--hue-from", "initial"])          # nor i_bar to take the hue from
    assert "0000_initial.exr is missing: --hue-from initial" in capsys.readouterr().err
    empty = tmp_path / "empty_run"
    empty.mkdir()
    with pytest.raises(SystemExit):
        main([str(run), "--image", "initial"])             # this run saved no i_bar
    assert "F_run/samples holds no <frame>_initial.exr" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main([str(empty)])
    assert "empty_run/samples holds no" in capsys.readouterr().err

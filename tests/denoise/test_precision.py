"""``mcd.denoise --precision`` (docs/denoise.md "Speed"): bf16 runs the network under autocast with
channels-last inputs and gives the fp32 output within bf16 rounding, on frames from disk and on a rendered
scene; a precision without a fast path on the device is refused before anything is read or written."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mcd.core.metrics import psnr
from mcd.data.exr import read_exr
from mcd.data.scenes import VENDORED_DIR
from mcd.denoise import weights
from mcd.denoise.cli import run
from mcd.lit import precision as lit_precision
from mcd.lit.precision import cpu_bf16_supported
from tests.denoise.helpers import render_sequence

needs_bf16 = pytest.mark.skipif(not cpu_bf16_supported(), reason="this CPU has no native bf16")


@needs_bf16
def test_bf16_frames_run_under_autocast_channels_last_and_match_fp32(tmp_path, monkeypatch):
    folder = tmp_path / "frames"
    render_sequence(folder, frames=2)
    seen: list[tuple[bool, bool]] = []
    real_load = weights.load

    def load(*args, **kwargs):
        loaded = real_load(*args, **kwargs)

        def hook(_module, inputs):
            channels_last = inputs[0]["c4"].is_contiguous(memory_format=torch.channels_last)
            seen.append((torch.is_autocast_enabled("cpu"), channels_last))

        loaded.model.register_forward_pre_hook(hook)
        return loaded

    monkeypatch.setattr(weights, "load", load)
    args = ["--checkpoint", "unet-cpu-small", "--no-progress"]
    full = run([str(folder), "-o", str(tmp_path / "fp32"), *args])
    calls = len(seen)
    half = run([str(folder), "-o", str(tmp_path / "bf16"), *args, "--precision", "bf16"])
    assert full["precision"] == "fp32" and half["precision"] == "bf16"
    assert seen[:calls] and not any(a or cl for a, cl in seen[:calls]), seen  # fp32: no autocast, NCHW
    assert seen[calls:] and all(a and cl for a, cl in seen[calls:]), seen
    for f in range(2):
        a, b = (read_exr(tmp_path / d / f"cbox_{f:04d}.exr") for d in ("fp32", "bf16"))
        assert b.dtype == np.float32 and np.isfinite(b).all()
        assert psnr(b, a) > 45  # bf16 rounding (about 64 dB here), not a different result


@pytest.mark.slow
@needs_bf16
def test_bf16_denoises_a_rendered_scene_as_well_as_fp32(tmp_path):
    """F-cpu-small renders adaptively; in bf16 its sampling map may round differently, so the two runs are
    compared through their PSNR against the same reference, not pixel by pixel."""
    scene = VENDORED_DIR / "cbox" / "scene.xml"
    common = ["--scene", str(scene), "--checkpoint", "F-cpu-small", "--width", "48", "--height", "32",
              "--reference-spp", "256", "--reference-db", "0", "--no-progress"]
    full = run(["-o", str(tmp_path / "fp32"), *common])
    half = run(["-o", str(tmp_path / "bf16"), *common, "--precision", "bf16"])
    a, b = full["frames"][0], half["frames"][0]
    assert b["samples"] == b["budget_samples"]  # the budget holds in bf16 too
    assert b["psnr_output"] > b["psnr_adaptive"] and abs(b["psnr_output"] - a["psnr_output"]) < 0.5, (a, b)


def test_fp16_on_the_cpu_is_refused_before_anything_is_written(tmp_path, capsys):
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as stop:
        run([str(tmp_path / "no_frames_needed"), "-o", str(out), "--checkpoint", "unet-cpu-small",
             "--precision", "fp16"])
    assert stop.value.code == 2 and not out.exists()
    assert "--precision=fp16 runs on a GPU only" in capsys.readouterr().err


def test_bf16_on_a_cpu_without_native_bf16_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(lit_precision, "cpu_bf16_supported", lambda: False)  # what the check asks
    with pytest.raises(SystemExit):
        run([str(tmp_path), "-o", str(tmp_path / "out"), "--checkpoint", "unet-cpu-small",
             "--precision", "bf16"])
    assert "no native bf16" in capsys.readouterr().err and not (tmp_path / "out").exists()

"""Input (a) end to end (docs/denoise.md): a 32x32 Cornell-box sequence rendered to EXR files, denoised from
disk through the console script with a bundled checkpoint, beats its input; tiles under a memory cap agree
with the whole frame; FastDVDnet's window and the bundles' provenance."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mcd.core.metrics import psnr
from mcd.data.exr import read_exr
from mcd.denoise.cli import run
from mcd.denoise.frames import read_channels
from mcd.denoise.weights import BUNDLED_DIR, bundled_names
from tests.denoise.helpers import console_script, render_sequence, untrained_bundle

BUNDLED = ("F-cpu-small", "unet-cpu-small")


@pytest.fixture(scope="module")
def sequence(tmp_path_factory):
    folder = tmp_path_factory.mktemp("frames")
    refs = render_sequence(folder, frames=4, spp=4, ref_spp=1024)
    return folder, refs


def test_bundled_checkpoints_are_package_data_with_provenance():
    assert set(BUNDLED) <= set(bundled_names())
    for name in BUNDLED:
        meta = json.loads((BUNDLED_DIR / f"{name}.json").read_text())
        assert meta["command"].startswith("python -m mcd.run")
        assert meta["metrics"]["commit"] != "unknown" or len(meta.get("source_commit", "")) == 40
        assert meta["metrics"]["data_profile"] == "small"
        assert meta["config"]["capacity"]
        assert meta["metrics"]["psnr"] > meta["metrics"]["input_psnr"]  # it beat its noisy input when tested
        assert (BUNDLED_DIR / meta["weights_file"]).stat().st_size < 8e6


@pytest.mark.slow
def test_console_script_denoises_frames_from_disk_better_than_the_input(sequence, tmp_path):
    folder, refs = sequence
    out = tmp_path / "out"
    done = console_script(str(folder), "-o", str(out), "--checkpoint", "unet-cpu-small", "--no-progress")
    assert done.returncode == 0, done.stderr[-3000:]
    gains = []
    for f, ref in enumerate(refs):
        chans = read_channels(folder / f"cbox_{f:04d}.exr")
        noisy = np.stack([chans[c] for c in "RGB"], -1)
        denoised = read_exr(out / f"cbox_{f:04d}.exr")
        assert denoised.shape == (32, 32, 3) and (out / f"cbox_{f:04d}.png").is_file()
        gains.append(psnr(denoised, ref) - psnr(noisy, ref))
    assert np.mean(gains) > 0, gains
    report = json.loads((out / "denoise.json").read_text())
    assert report["provenance"]["name"] == "unet-cpu-small" and report["frames"] == 4


def test_tiles_under_a_memory_cap_agree_with_the_whole_frame(tmp_path):
    folder = tmp_path / "frames"
    render_sequence(folder, frames=2, size=96)
    args = ["--checkpoint", "unet-cpu-small", "--no-progress"]
    whole = run([str(folder), "-o", str(tmp_path / "whole"), *args])
    tiled = run([str(folder), "-o", str(tmp_path / "tiled"), *args, "--max-memory-mb", "10",
                 "--overlap", "16"])
    assert whole["tiles"] == 1 and tiled["tiles"] == 4
    for f in range(2):
        a, b = (read_exr(tmp_path / d / f"cbox_{f:04d}.exr") for d in ("whole", "tiled"))
        assert psnr(b, a) > 40


def test_a_memory_cap_too_small_for_any_tile_is_refused(sequence, tmp_path, capsys):
    folder, _ = sequence
    with pytest.raises(SystemExit):
        run([str(folder), "-o", str(tmp_path), "--checkpoint", "unet-cpu-small", "--max-memory-mb", "0.01"])
    assert "--max-memory-mb=0.01: too small" in capsys.readouterr().err


def test_fastdvdnet_reads_its_window_of_neighbours(sequence, tmp_path):
    folder, _ = sequence
    fdv = untrained_bundle(tmp_path, "fastdvdnet", "+experiment=fastdvdnet", "capacity=cpu")
    report = run([str(folder), "-o", str(tmp_path / "out"), "--checkpoint", str(fdv), "--no-progress"])
    assert report["frames"] == 4 and all((tmp_path / "out" / f"cbox_{f:04d}.exr").is_file() for f in range(4))


def test_models_run_under_inference_mode_where_the_cpu_fast_paths_apply(sequence, tmp_path, monkeypatch):
    """The CPU fast paths of mcd/models/cpu_fast/ghost_conv.py apply only under torch.inference_mode
    (docs/inference.md); docs/denoise.md "Speed" has what no_grad cost F. The first call is the tile planner's
    memory probe (mcd/denoise/tiles.py), which runs plain no_grad so that every submodule's output counts."""
    import torch

    from mcd.denoise import weights

    modes: list[bool] = []
    real_load = weights.load

    def load(*args, **kwargs):
        loaded = real_load(*args, **kwargs)
        loaded.model.register_forward_pre_hook(lambda *_: modes.append(torch.is_inference_mode_enabled()))
        return loaded

    monkeypatch.setattr(weights, "load", load)
    folder, _ = sequence
    run([str(folder), "-o", str(tmp_path / "out"), "--checkpoint", "unet-cpu-small", "--no-progress"])
    assert len(modes) > 1 and not modes[0] and all(modes[1:]), modes

"""Campaign 11, part 2 (notes/reliability_campaigns.md): a checkpoint whose weights hold NaN or Inf (a run
that diverged) was denoised with, exit 0, without a word: the network's outputs were non-finite, and the
output bound (docs/method.md "Output") replaced every one by the render's 3x3 mean, so ``mcd-denoise`` wrote a
blur and scored it as the network's output (20.58 dB against the clean bundle's 20.18 dB); ``python -m
mcd.bundle`` shipped such weights with the run's test scores. Both refuse them now, naming the file and the
tensors, before anything is written (:func:`mcd.denoise.weights.check_finite`). Real bundles, a real run of
``ab_sweep``."""

from __future__ import annotations

import hashlib
import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from mcd.denoise.weights import BUNDLED_DIR
from tests.conftest import module_env
from tests.reliability.denoise_helpers import refused, write_frames
from tests.test_run import REPO


def _nan_bundle(tmp_path: Path) -> Path:
    """The bundled U-Net with NaN in its last convolution, its JSON's SHA-256 written for the new bytes."""
    weights = torch.load(BUNDLED_DIR / "unet-cpu-small.pt", weights_only=True)
    weights["denoiser.unet.head.weight"] = weights["denoiser.unet.head.weight"] * float("nan")
    pt = tmp_path / "diverged.pt"
    torch.save(weights, pt)
    meta = json.loads((BUNDLED_DIR / "unet-cpu-small.json").read_text())
    meta["sha256"] = hashlib.sha256(pt.read_bytes()).hexdigest()
    pt.with_suffix(".json").write_text(json.dumps(meta))
    return pt


def test_a_bundle_whose_weights_hold_nan_is_refused_before_anything_is_written(tmp_path, capsys):
    write_frames(tmp_path / "frames", n=2, size=(32, 32))
    pt = _nan_bundle(tmp_path)
    err = refused(capsys, str(tmp_path / "frames"), "-o", str(tmp_path / "out"), "--checkpoint", str(pt))
    assert "NaN or Inf" in err and "denoiser.unet.head.weight" in err and str(pt) in err, err
    assert not (tmp_path / "out").exists()


def _bundle(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mcd.bundle", *args], capture_output=True, text=True,
                          cwd=REPO, env=module_env(), timeout=600)


@pytest.mark.slow
def test_a_run_whose_checkpoint_holds_inf_is_neither_bundled_nor_denoised_with(ab_sweep, tmp_path, capsys):
    run = tmp_path / "A_spp4"
    shutil.copytree(ab_sweep / "multirun" / "ablation" / "tiny" / "A_spp4", run)
    (ckpt,) = (run / "checkpoints").glob("best*.ckpt")
    state = torch.load(ckpt, weights_only=True)
    name = next(k for k, v in state["state_dict"].items() if v.is_floating_point() and v.ndim == 4)
    state["state_dict"][name][0, 0, 0, 0] = float("inf")
    torch.save(state, ckpt)
    proc = _bundle(str(run), "--name", "diverged", "--out", str(tmp_path / "bundles"))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "NaN or Inf" in proc.stderr and name.removeprefix("model.") in proc.stderr, proc.stderr
    assert not any((tmp_path / "bundles").glob("*")), "a bundle was written"
    write_frames(tmp_path / "frames", n=2, size=(32, 32))
    err = refused(capsys, str(tmp_path / "frames"), "-o", str(tmp_path / "out"), "--checkpoint", str(run))
    assert "NaN or Inf" in err and str(ckpt) in err, err


@pytest.mark.parametrize("bundle", ["unet-cpu-small", "F-cpu-small"])
def test_the_shipped_bundles_are_finite(bundle):
    from mcd.denoise.weights import check_finite

    check_finite(torch.load(BUNDLED_DIR / f"{bundle}.pt", weights_only=True), "--checkpoint", bundle)


@pytest.mark.parametrize("value", [-1.0, 0.0, float("nan")])
def test_a_bundle_whose_configuration_breaks_a_rule_is_refused_naming_the_key(tmp_path, capsys, value):
    """A bundle's JSON with ``data.exposure_target`` -1 or NaN (its ``.pt`` unchanged, so its SHA-256 held)
    denoised every frame to black and scored it 100 dB, exit 0; 0 ended in a ZeroDivisionError traceback. The
    parts of the configuration the model is built and fed with are held to ``mcd.run``'s rules
    (:func:`mcd.denoise.weights.check_values`)."""
    write_frames(tmp_path / "frames", n=2, size=(32, 32))
    pt = tmp_path / "edited.pt"
    shutil.copy(BUNDLED_DIR / "unet-cpu-small.pt", pt)
    meta = json.loads((BUNDLED_DIR / "unet-cpu-small.json").read_text())
    meta["config"]["data"]["exposure_target"] = value
    pt.with_suffix(".json").write_text(json.dumps(meta))
    err = refused(capsys, str(tmp_path / "frames"), "-o", str(tmp_path / "out"), "--checkpoint", str(pt))
    assert "data.exposure_target=" in err and str(pt) in err, err
    assert not (tmp_path / "out").exists()

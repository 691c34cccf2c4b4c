"""The baselines' own losses (docs/baselines.md), registered in the project's loss registry."""

from __future__ import annotations

import pytest
import torch
from omegaconf import OmegaConf

from mcd.losses import build_loss
from mcd.losses.baselines import LoG, log_kernel

CONFS = {
    "rae": dict(w_s=0.8, w_g=0.1, w_t=0.1, sigma=1.5, frame_weights=[0.135, 0.325, 0.607, 0.882, 1.0]),
    "dasr": dict(eps=0.01, w_g=1.0, sigma=1.5),
    "ntasad": dict(w_s=1.0, w_t=1.0),
    "mse": {},
}


def build(name: str, **over):
    loss = dict(name=name, space="log1p", **CONFS[name])
    loss.update(over)
    return build_loss(OmegaConf.create({"loss": loss, "paths": {"vgg16_weights": None}}))


def clip(seed: int = 0, t: int = 5) -> torch.Tensor:
    return torch.rand(2, t, 3, 16, 16, generator=torch.Generator().manual_seed(seed)) * 5


@pytest.mark.parametrize("name", sorted(CONFS))
def test_zero_at_the_reference_positive_elsewhere_and_differentiable(name: str) -> None:
    loss = build(name)
    ref = clip(0)
    assert float(loss(ref, ref)["loss"]) == pytest.approx(0.0, abs=1e-7)
    pred = clip(1).requires_grad_(True)
    out = loss(pred, ref)
    assert out["loss"].item() > 0
    out["loss"].backward()
    assert pred.grad.abs().sum() > 0
    assert loss.perceptual_status.on is False and "paper" in loss.perceptual_status.reason


def test_matches_the_config_files() -> None:
    from pathlib import Path

    conf = Path(__file__).resolve().parents[2] / "conf" / "loss"
    for name, values in CONFS.items():
        cfg = OmegaConf.load(conf / f"{name}.yaml")
        assert cfg.name == name and "module" not in cfg
        assert {k: cfg[k] for k in values} == values


def test_rae_weights_later_frames_more() -> None:
    loss = build("rae", w_g=0.0, w_t=0.0)
    ref = torch.zeros(1, 5, 3, 8, 8)
    early, late = ref.clone(), ref.clone()
    early[:, 0] += 1.0
    late[:, 4] += 1.0
    assert float(loss(late, ref)["loss"]) > 5 * float(loss(early, ref)["loss"])
    with pytest.raises(ValueError, match="frame_weights"):
        loss(torch.zeros(1, 6, 3, 8, 8), torch.zeros(1, 6, 3, 8, 8))


def test_temporal_terms_see_flicker_that_l1_alone_would_not_separate() -> None:
    """Same per-frame L1 error, but flickering sign: the temporal term is larger."""
    ref = torch.ones(1, 5, 3, 8, 8)
    steady = ref + 0.1
    flicker = ref + 0.1 * torch.tensor([1, -1, 1, -1, 1.0]).view(1, 5, 1, 1, 1)
    loss = build("ntasad")
    assert float(loss(flicker, ref)["l_t"]) > float(loss(steady, ref)["l_t"]) + 0.05
    assert float(loss(flicker, ref)["l1"]) == pytest.approx(float(loss(steady, ref)["l1"]), rel=0.05)


def test_dasr_relative_error_weighs_dark_pixels_more() -> None:
    loss = build("dasr", w_g=0.0)
    ref = torch.full((1, 1, 3, 8, 8), 0.05)
    ref[..., 4:] = 50.0
    dark, bright = ref.clone(), ref.clone()
    dark[..., :4] += 0.1
    bright[..., 4:] += 20.0  # bright pixels are off by more in log space too
    assert float(loss(dark, ref)["loss"]) > float(loss(bright, ref)["loss"])


def test_log_kernel_is_zero_sum_and_flat_images_give_zero() -> None:
    k = log_kernel(1.5)
    assert k.shape == (11, 11) and abs(float(k.sum())) < 1e-6 and float(k[5, 5]) < 0
    flat = torch.full((2, 3, 9, 9), 7.0)
    assert float(LoG(1.5)(flat).abs().max()) < 1e-4


def test_bad_clips_are_errors() -> None:
    with pytest.raises(ValueError, match="ntasad"):
        build("ntasad")(torch.zeros(1, 1, 3, 8, 8), torch.zeros(1, 1, 3, 8, 8))
    with pytest.raises(ValueError, match="shape"):
        build("mse")(torch.zeros(1, 2, 3, 8, 8), torch.zeros(1, 2, 3, 8, 9))

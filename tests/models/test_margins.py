"""Every convolutional method's denoiser reads its input reflected by ``method.denoiser_margin`` pixels
outside training, and the crop as it is in training (mcd/models/margin.py; docs/method.md and
docs/baselines.md "Frame edges"): row F and the U-Net (``F_d``), RAE, FastDVDnet, DASR, NTASAD. Real
forward passes of the methods as their experiments configure them."""

from __future__ import annotations

import pytest
import torch
import torch.nn.functional as F
from omegaconf import OmegaConf

from mcd.data.buffers import BUFFERS
from mcd.data.synthetic import synthetic_frame
from mcd.models.registry import build
from tests.conftest import compose_cfg

#: experiment -> the attribute holding its denoiser network (the first module that reads the margin)
DENOISERS = {"F": "denoiser", "unet": "denoiser", "rae": "net", "fastdvdnet": "stage1", "dasr": "denoiser",
             "ntasad": "denoiser"}
MARGIN = 16


def model_of(experiment: str, *overrides: str) -> torch.nn.Module:
    torch.manual_seed(0)
    return build(compose_cfg(f"+experiment={experiment}", "budget=4", *overrides))


def clip(model: torch.nn.Module, h: int, w: int, seed: int = 0) -> dict[str, torch.Tensor]:
    """One input of `model` at ``h x w``: a frame, or a window of frames for a windowed method."""
    past, future = model.window
    t = past + 1 + future
    lead = (1,) if t == 1 else (1, t)
    return synthetic_frame(BUFFERS, h, w, lead, seed, colour_scale=4.0, depth_scale=20.0)


def network_input(model: torch.nn.Module, experiment: str, x: dict, train: bool) -> torch.Tensor:
    """What the denoiser network reads for `x` in training or evaluation (a sequence's first frame)."""
    seen: list[torch.Tensor] = []
    net = getattr(model, DENOISERS[experiment])
    handle = net.register_forward_pre_hook(lambda _m, args: seen.append(args[0].detach().clone()))
    try:
        model.train(train)
        model.reset()
        with torch.no_grad():
            model(x)
    finally:
        handle.remove()
    return seen[0]


@pytest.mark.parametrize("experiment", list(DENOISERS))
def test_the_denoiser_reads_the_reflected_frame_in_evaluation_and_the_crop_in_training(experiment):
    """The configured margin is 16 for every method; in evaluation the denoiser network's input is its
    training input reflected by 16 pixels on every side (then padded to the network's stride at the bottom
    and right, as in training); in training it is the frame itself."""
    model = model_of(experiment)
    assert model.denoiser_margin == MARGIN
    h, w = 21, 27
    x = clip(model, h, w)
    trained = network_input(model, experiment, x, train=True)
    evaluated = network_input(model, experiment, x, train=False)
    assert trained.shape[-2] < h + 2 * MARGIN <= evaluated.shape[-2]
    assert trained.shape[-1] < w + 2 * MARGIN <= evaluated.shape[-1]
    frame = trained[..., :h, :w]
    expected = F.pad(frame, (MARGIN,) * 4, mode="reflect")
    torch.testing.assert_close(evaluated[..., : h + 2 * MARGIN, : w + 2 * MARGIN], expected)


@pytest.mark.parametrize("experiment", list(DENOISERS))
@pytest.mark.parametrize("size", [(9, 13), (21, 27), (5, 7)])
def test_outputs_keep_their_size_on_odd_frames_and_frames_smaller_than_the_margin(experiment, size):
    """A frame smaller than the margin is reflected as far as it goes (``H - 1``, ``W - 1``); two frames in
    a row, so that a recurrent method's state (RAE's hidden states, NTASAD's warped previous output) carries
    across frames at a consistent size; NTASAD feeds back its output at the frame's size."""
    model = model_of(experiment).eval()
    model.reset()
    with torch.no_grad():
        for seed in (0, 1):
            out = model(clip(model, *size, seed=seed))["output"]
            assert out.shape[-2:] == size and torch.isfinite(out).all()
    if experiment == "ntasad":
        assert model.prev.shape[-2:] == size


@pytest.mark.parametrize("experiment", list(DENOISERS))
def test_the_margin_changes_the_edge_and_zero_turns_it_off(experiment):
    """The margin changes what the frame's edge pixels see; ``method.denoiser_margin=0`` runs the denoiser on
    the frame as in training. The weights are moved off their initialisation first (the same way for both
    models): FastDVDnet starts as the identity, whose output no margin changes."""
    x = clip(model_of(experiment), 24, 24)
    outs = {}
    for margin in (MARGIN, 0):
        model = model_of(experiment, f"method.denoiser_margin={margin}").eval()
        gen = torch.Generator().manual_seed(1)
        with torch.no_grad():
            for p in model.parameters():
                p.add_(0.05 * torch.randn(p.shape, generator=gen))
        model.reset()
        with torch.no_grad():
            outs[margin] = model(x)["output"]
    assert float((outs[MARGIN] - outs[0])[..., 0, :].abs().max()) > 1e-6
    off = model_of(experiment, "method.denoiser_margin=0")
    x = clip(off, 21, 27)
    assert network_input(off, experiment, x, train=False).shape == network_input(off, experiment, x,
                                                                                 train=True).shape


@pytest.mark.parametrize("experiment", list(DENOISERS))
def test_configs_from_before_the_key_run_without_a_margin(experiment):
    """A checkpoint's config written before the key (the bundled ones) loads with margin 0."""
    cfg = compose_cfg(f"+experiment={experiment}", "budget=4")
    OmegaConf.set_struct(cfg, False)
    del cfg.method["denoiser_margin"]
    assert build(cfg).denoiser_margin == 0


@pytest.mark.parametrize("experiment", ["noisy", "oidn"])
def test_a_margin_on_a_method_without_a_denoiser_of_its_own_is_refused(experiment):
    cfg = compose_cfg(f"+experiment={experiment}", "budget=4", "+method.denoiser_margin=16")
    if experiment == "oidn":
        pytest.importorskip("pyoidn")
    with pytest.raises(ValueError, match="method.denoiser_margin=16: method .* has no denoiser"):
        build(cfg)
    cfg.method.denoiser_margin = 0
    assert not hasattr(build(cfg), "denoiser_margin")


def test_a_negative_margin_is_refused_naming_the_key():
    cfg = compose_cfg("+experiment=rae", "budget=4")
    cfg.method.denoiser_margin = -1
    with pytest.raises(ValueError, match="method.denoiser_margin=-1"):
        build(cfg)

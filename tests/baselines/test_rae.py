"""RAE (docs/baselines.md "RAE"): recurrent state persists across frames, resets between sequences."""

from __future__ import annotations

import pytest
import torch

from mcd.models.baselines.rae import DEMOD_EPS, DEMOD_FULL, RAE, demodulation

from .helpers import frame

SMALL = dict(encoder=[8, 8, 8, 8, 8], bottleneck=8, last=[8, 8])


@pytest.fixture
def rae() -> RAE:
    torch.manual_seed(0)
    return RAE(4, **SMALL).eval()


@torch.no_grad()
def test_state_persists_across_frames_and_resets(rae: RAE) -> None:
    a, b = frame(seed=1), frame(seed=2)
    fresh_b = rae(b)["output"]
    rae.reset()
    rae(a)
    after_a = rae(b)["output"]
    assert not torch.allclose(after_a, fresh_b, atol=1e-6), "frame b ignores the state left by frame a"
    state = [blk.state for blk in rae.net.encoder]
    assert all(s is not None for s in state)
    rae.reset()
    assert all(blk.state is None for blk in rae.net.encoder) and rae.net.bottleneck.state is None
    assert torch.equal(rae(b)["output"], fresh_b), "reset() must make the next frame start from a zero state"


def test_state_of_another_size_without_reset_is_an_error(rae: RAE) -> None:
    with torch.no_grad():
        rae(frame(h=32, w=32))
        with pytest.raises(RuntimeError, match="reset"):
            rae(frame(h=64, w=32))


def test_gradient_flows_through_time(rae: RAE) -> None:
    """The second frame's output depends on the first frame's input (backprop through the hidden state)."""
    a, b = frame(seed=1), frame(seed=2)
    a["c4"].requires_grad_(True)
    rae(a)
    rae(b)["output"].sum().backward()
    assert a["c4"].grad is not None and a["c4"].grad.abs().sum() > 0


@torch.no_grad()
def test_odd_sizes_hdr_and_black_albedo(rae: RAE) -> None:
    x = frame(h=37, w=21)
    x["c4"][..., :5, :5] = 1e4
    x["albedo"][..., 10:, :] = 0.0
    y = rae(x)["output"]
    assert y.shape == (1, 3, 37, 21) and torch.isfinite(y).all() and (y >= 0).all()


def test_missing_buffer_names_it(rae: RAE) -> None:
    x = frame()
    del x["albedo"]
    with pytest.raises(KeyError, match="albedo"):
        rae(x)


def test_required_buffers_read_the_uniform_render_not_the_stack() -> None:
    assert RAE(8, **SMALL).required_buffers() == {"c8", "depth", "normal", "albedo"}
    with pytest.raises(ValueError, match="budget"):
        RAE(3, **SMALL)


def test_demodulation_leaves_lights_alone_and_divides_lit_surfaces() -> None:
    """An area light has albedo 0 in Mitsuba's AOV: its radiance enters the network as it is, not 100x
    brighter; an albedo of at least DEMOD_FULL is divided out as ``albedo + DEMOD_EPS``; the divisor is
    continuous and positive between the two."""
    albedo = torch.tensor([0.0, 0.0, 0.0, 0.05, 0.02, 0.01, 0.5, 0.25, 0.1, 1.0, 1.0, 1.0]).view(4, 3, 1, 1)
    d = demodulation(albedo)
    assert torch.equal(d[0], torch.ones(3, 1, 1))
    assert torch.allclose(d[2], albedo[2] + DEMOD_EPS) and torch.allclose(d[3], albedo[3] + DEMOD_EPS)
    assert (d[1] > albedo[1] + DEMOD_EPS).all() and (d[1] < 1).all()
    ramp = torch.linspace(0, 2 * DEMOD_FULL, 201).view(-1, 1, 1, 1).expand(-1, 3, 1, 1)
    steps = demodulation(ramp).flatten().diff().abs()
    assert steps.max() < 0.02 and (demodulation(ramp) > 0).all()


@torch.no_grad()
def test_light_with_zero_albedo_is_not_amplified(rae: RAE) -> None:
    """The network's colour input on a light (albedo 0, radiance 65) is log1p(65), not log1p(6500)."""
    x = frame(h=16, w=16)
    x["c4"][:] = 65.0
    x["albedo"][:] = 0.0
    seen = {}
    handle = rae.net.encoder[0].c1.register_forward_pre_hook(lambda m, a: seen.setdefault("in", a[0]))
    rae(x)
    handle.remove()
    colour = seen["in"][:, :3, :16, :16]  # the input is padded to the network's stride
    assert torch.allclose(colour, torch.log1p(torch.tensor(65.0)).expand(1, 3, 16, 16))

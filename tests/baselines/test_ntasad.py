"""NTASAD (docs/baselines.md "NTASAD"): output feedback across frames, hierarchical kernels, budgeted
sampling."""

from __future__ import annotations

import pytest
import torch

from mcd.models.baselines.ntasad import NTASAD, combine

from .helpers import frame


def model() -> NTASAD:
    torch.manual_seed(0)
    return NTASAD(4, enc=6, dec=8, full=8)


@torch.no_grad()
def test_first_frame_feeds_back_the_uniform_render_then_the_warped_output() -> None:
    net = model().eval()
    a, b = frame(seed=1), frame(seed=2)
    assert net.previous(a) is a["c4"]
    out_a = net(a)["output"]
    torch.testing.assert_close(net.previous(b), out_a, rtol=1e-4, atol=1e-4)  # zero motion: identity warp
    b_after_a = net(b)["output"]
    net.reset()
    assert net.prev is None
    b_fresh = net(b)["output"]
    assert not torch.allclose(b_after_a, b_fresh, atol=1e-6), "the fed-back output changes nothing"
    net.reset()
    torch.testing.assert_close(net(b)["output"], b_fresh)


@torch.no_grad()
def test_feedback_is_warped_by_the_motion_vectors() -> None:
    net = model().eval()
    a, b = frame(seed=1, w=40), frame(seed=2, w=40)
    out_a = net(a)["output"]
    b["motion"][:, 0] = -3.0  # frame b = frame a moved 3 px right
    torch.testing.assert_close(net.previous(b)[..., 3:], out_a[..., :-3], rtol=1e-4, atol=1e-4)


def test_map_keeps_budget_and_both_networks_learn() -> None:
    net = model()
    x = frame(b=2, h=27, w=35, seed=5)
    out = net(x)
    m = out["sampling_map"]
    assert m.sum((1, 2, 3)).tolist() == [27 * 35 * 3] * 2
    assert out["output"].shape == (2, 3, 27, 35) and (out["output"] >= 0).all()
    (torch.log1p(out["output"]) - torch.log1p(x["ref"])).abs().mean().backward()
    for part in (net.sampler, net.denoiser):
        assert sum(p.grad.abs().sum() for p in part.parameters() if p.grad is not None) > 0


def test_combine_keeps_the_fine_band_and_takes_the_coarse_low_band() -> None:
    fine = torch.rand(1, 3, 16, 16)
    coarse = torch.rand(1, 3, 8, 8)
    torch.testing.assert_close(combine(fine, coarse, torch.zeros(1, 1, 16, 16)), fine)
    # With a = 1 and a coarse level equal to the fine level's own low band, the result is the fine level.
    low = torch.nn.functional.avg_pool2d(fine, 2)
    torch.testing.assert_close(combine(fine, low, torch.ones(1, 1, 16, 16)), fine)


def test_hdr_fireflies_stay_finite() -> None:
    x = frame(seed=3)
    for k in ("c1", "c2", "c4", "c8", "c16", "c32", "c1_in"):
        x[k][..., 3, 3] = 1e4
    with torch.no_grad():
        y = model().eval()(x)["output"]
    assert torch.isfinite(y).all()


def test_reads_motion_and_the_stack_and_needs_reset_between_sizes() -> None:
    net = model().eval()
    assert {"motion", "c1_in", "c32", "c4", "depth"} <= net.required_buffers()
    with torch.no_grad():
        net(frame(h=32, w=32))
        with pytest.raises(RuntimeError, match="reset"):
            net(frame(h=16, w=32))

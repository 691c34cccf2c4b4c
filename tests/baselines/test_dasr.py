"""DASR (docs/baselines.md "DASR"): the sampling map keeps its budget; the sampler learns through DASR's
gradient.
"""

from __future__ import annotations

import pytest
import torch

from mcd.models.baselines.dasr import DASR

from .helpers import frame

SMALL = dict(encoder=[6, 6, 6, 6, 6], bottleneck=6, last=[6, 6])


@pytest.mark.parametrize(("budget", "h", "w"), [(4, 32, 32), (2, 19, 27), (8, 40, 24)])
def test_map_keeps_its_budget(budget: int, h: int, w: int) -> None:
    torch.manual_seed(0)
    net = DASR(budget, **SMALL).eval()
    x = frame(b=2, h=h, w=w)
    with torch.no_grad():
        out = net(x)
    m = out["sampling_map"]
    assert m.shape == (2, 1, h, w)
    assert torch.equal(m, m.round()) and m.min() >= 0 and m.max() <= 63
    assert m.sum((1, 2, 3)).tolist() == [h * w * (budget - 1)] * 2
    assert out["output"].shape == (2, 3, h, w) and torch.isfinite(out["output"]).all()


def test_sampler_gets_a_gradient_through_the_adaptive_render() -> None:
    torch.manual_seed(0)
    net = DASR(4, **SMALL)
    x = frame(seed=4)
    out = net(x)["output"]
    (torch.log1p(out) - torch.log1p(x["ref"])).abs().mean().backward()
    g_s = sum(p.grad.abs().sum() for p in net.sampler.parameters() if p.grad is not None)
    g_d = sum(p.grad.abs().sum() for p in net.denoiser.parameters() if p.grad is not None)
    assert g_s > 0 and g_d > 0


def test_reads_c1_in_and_the_stack() -> None:
    assert DASR(4, **SMALL).required_buffers() == {"c1_in", "c1", "c2", "c4", "c8", "c16", "c32", "depth",
                                                   "normal", "albedo"}
    with pytest.raises(ValueError, match="budget"):
        DASR(0.5, **SMALL)

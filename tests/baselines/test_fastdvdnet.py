"""FastDVDnet (docs/baselines.md "FastDVDnet"): 5-frame window, two stages; the output depends on all 5
frames."""

from __future__ import annotations

import pytest
import torch

from mcd.models.baselines.fastdvdnet import FastDVDnet

from .helpers import frame


def model() -> FastDVDnet:
    torch.manual_seed(0)
    return FastDVDnet(4, (8, 12, 16), 6)


def test_starts_as_the_identity_on_the_centre_frame() -> None:
    x = frame(t=5)
    with torch.no_grad():
        out = model().eval()(x)["output"]
    torch.testing.assert_close(out, x["c4"][:, 2], rtol=1e-5, atol=1e-5)


def test_output_depends_on_all_five_frames() -> None:
    net = model().eval()
    for block in (net.stage1, net.stage2):  # as after training: the zero-initialised residual convs are not 0
        torch.nn.init.normal_(block.outc[-1].weight, std=0.1)
    x = frame(t=5)
    x["c4"].requires_grad_(True)
    out = net(x)["output"]
    assert out.shape == (1, 3, 32, 32)
    out.sum().backward()
    per_frame = x["c4"].grad.abs().sum((0, 2, 3, 4))
    assert (per_frame > 0).all(), f"gradient per window frame {per_frame.tolist()}: some frame is ignored"
    # The G-buffers of every frame reach the output too (stage 1 for all five, stage 2 for t-1..t+1).
    assert net.window == (2, 2)


def test_needs_a_five_frame_window() -> None:
    with pytest.raises(ValueError, match="5-frame"):
        model()(frame())


@torch.no_grad()
def test_odd_sizes_and_hdr() -> None:
    x = frame(t=5, h=19, w=30)
    x["c4"][:, :, :, 0, 0] = 2e4
    y = model().eval()(x)["output"]
    assert y.shape == (1, 3, 19, 30) and torch.isfinite(y).all()


def test_one_training_step_lowers_the_loss() -> None:
    net = model().train()
    x = frame(t=5, b=2, seed=3)
    ref = x["ref"][:, 2]
    opt = torch.optim.Adam(net.parameters(), lr=1e-3)
    losses = []
    for _ in range(5):
        loss = (torch.log1p(net(x)["output"]) - torch.log1p(ref)).abs().mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(loss.item())
    assert losses[-1] < losses[0]

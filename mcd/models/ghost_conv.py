"""Fast GhostConv (paper Sec. 3.2 "Fast GhostConv"; method.md "Fast GhostConv").

A large-kernel group convolution gathers a wide neighbourhood cheaply; a point-wise convolution mixes its
channels into half the output; a depth-wise 3x3 convolution on that half makes the other ("ghost") half;
concatenation and ReLU. It replaces every 3x3 conv + ReLU block of the sampling network ``F_s``.

PyTorch's CPU backward of grouped convolutions is an order of magnitude slower than a dense one of the same
shape, so when training on the CPU the group and depth-wise convolutions run as dense convolutions with
block-diagonal (masked) weights: the same function, parameters and gradients. Inference, MAC counting and
other devices use the grouped convolutions (whose MACs are the block's true cost).

The group convolution's output width is not given by the paper; it is ``mid_ratio * cout`` (default 0.5),
which makes the block cheaper than the 3x3 block it replaces, as the paper's component table requires (rows
E, G, H, L lose params and MACs against D, C, J, B). Groups fall back to ``gcd(groups, cin, mid)`` when
``groups`` does not divide both widths (e.g. an input layer of 12 channels with groups 8).
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import Tensor, nn


class FastGhostConv(nn.Module):
    """``cin -> cout`` Fast GhostConv block (``cout`` must be even: half primary, half ghost)."""

    def __init__(self, cin: int, cout: int, kernel: int = 7, groups: int = 4, mid_ratio: float = 0.5) -> None:
        super().__init__()
        if cout % 2:
            raise ValueError(f"FastGhostConv needs an even output width (half primary, half ghost); "
                             f"got {cout}")
        if kernel % 2 == 0:
            raise ValueError(f"FastGhostConv needs an odd group-conv kernel size; got {kernel}")
        mid = max(1, round(cout * mid_ratio))
        g = math.gcd(groups, math.gcd(cin, mid))
        half = cout // 2
        self.group = nn.Conv2d(cin, mid, kernel, padding=kernel // 2, groups=g)
        self.point = nn.Conv2d(mid, half, 1)
        self.ghost = nn.Conv2d(half, half, 3, padding=1, groups=half)
        self.act = nn.ReLU(inplace=True)

    def forward(self, x: Tensor) -> Tensor:
        primary = self.point(grouped_conv(self.group, x))
        return self.act(torch.cat([primary, grouped_conv(self.ghost, primary)], 1))


def grouped_conv(conv: nn.Conv2d, x: Tensor) -> Tensor:
    """``conv(x)``; when training on the CPU a grouped ``conv`` runs dense with a block-diagonal weight."""
    g = conv.groups
    if g == 1 or x.device.type != "cpu" or not torch.is_grad_enabled():
        return conv(x)
    cout, cin_g = conv.weight.shape[:2]
    mask = torch.block_diag(*[x.new_ones(cout // g, cin_g) for _ in range(g)])[:, :, None, None]
    return F.conv2d(x, conv.weight.repeat(1, g, 1, 1) * mask, conv.bias, padding=conv.padding)

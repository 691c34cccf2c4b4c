"""Fast GhostConv (paper Sec. 4.2 "Fast GhostConv"; docs/method.md "Fast GhostConv").

A large-kernel group convolution gathers a wide neighbourhood cheaply; a point-wise convolution mixes its
channels into half the output; a depth-wise 3x3 convolution on that half makes the other ("ghost") half;
concatenation and ReLU. It replaces every 3x3 conv + ReLU block of the sampling network ``F_s``.

PyTorch's CPU backward of grouped convolutions is an order of magnitude slower than a dense one of the same
shape, so when training on the CPU the group and depth-wise convolutions run as dense convolutions with
block-diagonal (masked) weights: the same function, parameters and gradients. MAC counting and other devices
use the grouped convolutions (whose MACs are the block's true cost).

CPU inference (docs/inference.md, "Grouped convolutions"): oneDNN computes each group's output channels in
blocks of :data:`LANES`, so a group of 2 or 5 outputs leaves most of every block empty (a 7x7 group conv with
2 outputs per group runs at a fifth of a dense 3x3 conv's MACs per second). :func:`lane_filled_conv` fills
the blocks with ``S`` horizontally adjacent outputs: a stride-``(1, S)`` convolution whose ``S * cout_g``
outputs per group hold the same kernel shifted by ``0 .. S - 1`` columns (width ``k + S - 1``), then one
copy interleaves the ``S`` phases back into columns. Same function (the zero taps add nothing), chosen per
layer by :func:`lane_stride`'s cost model. Blocks whose groups have at most :data:`SPLIT_MAX_OUT` outputs and
whose input has at most :data:`SPLIT_MAX_IN` channels instead run :func:`split_depthwise_point`: one
depth-wise convolution per output of a group (oneDNN vectorises those over the input channels) with the
point-wise convolution folded in, which sums over each group's inputs.

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
        if split_depthwise_applies(self.group, x):
            primary = split_depthwise_point(self.group, self.point, x)
        else:
            primary = self.point(grouped_conv(self.group, x))
        return self.act(torch.cat([primary, grouped_conv(self.ghost, primary)], 1))


#: Output channels oneDNN's CPU convolutions compute together (one AVX-512 register of fp32, or of bf16
#: pairs): a group's outputs are padded to a multiple of this.
LANES = 16
#: Cost of interleaving one output channel of the ``S`` phases back into columns, in the units of
#: :func:`lane_stride` (MACs of one lane); measured on the shapes of ``F_s`` (docs/inference.md).
INTERLEAVE_COST = 100


def lane_stride(cin_g: int, cout_g: int, kernel: int) -> int:
    """The ``S`` in 1..16 that minimises the modelled cost per output pixel of a group conv with ``cin_g``
    inputs and ``cout_g`` outputs per group: ``cin_g * ceil(S cout_g / LANES) * LANES * (k + S - 1) / S``
    lane-MACs, plus :data:`INTERLEAVE_COST` per output channel when ``S > 1``."""
    def cost(s: int) -> float:
        lanes = -(-s * cout_g // LANES) * LANES
        return cin_g * lanes * (kernel + s - 1) / s + (INTERLEAVE_COST * cout_g if s > 1 else 0)

    return min(range(1, LANES + 1), key=lambda s: (cost(s), s))


def lane_filled_conv(conv: nn.Conv2d, x: Tensor, stride: int) -> Tensor:
    """``conv(x)`` for a stride-1, zero-padded group ``conv``, computed as a stride-``(1, stride)`` conv with
    ``stride`` column phases per output channel (see the module docstring). ``stride = 1`` is ``conv(x)``."""
    if stride == 1:
        return conv(x)
    g, s = conv.groups, stride
    cout, cin_g, kh, kw = conv.weight.shape
    cout_g = cout // g
    weight = conv.weight.new_zeros(g, s, cout_g, cin_g, kh, kw + s - 1)
    for phase in range(s):
        weight[:, phase, ..., phase : phase + kw] = conv.weight.view(g, cout_g, cin_g, kh, kw)
    bias = None if conv.bias is None else conv.bias.view(g, 1, cout_g).expand(g, s, cout_g).reshape(-1)
    b, _, h, w = x.shape
    wo = -(-w // s)
    if wo * s != w:                              # zero columns on the right; their outputs are cropped
        x = F.pad(x, (0, wo * s - w))
    y = F.conv2d(x, weight.view(g * s * cout_g, cin_g, kh, kw + s - 1), bias, stride=(1, s),
                 padding=conv.padding, groups=g)                              # [B, (g, phase, o), H, wo]
    y = y.permute(0, 2, 3, 1).reshape(b, h, wo, g, s, cout_g).transpose(3, 4).reshape(b, h, wo * s, cout)
    return y[:, :, :w].permute(0, 3, 1, 2).contiguous(memory_format=torch.channels_last)


#: :func:`split_depthwise_point` runs where a group has at most this many outputs and the block's input at
#: most :data:`SPLIT_MAX_IN` channels: the widths where it measured faster than :func:`lane_filled_conv`
#: (docs/inference.md, "Measured: the group convolutions"; oneDNN's depth-wise rate falls for wider inputs).
SPLIT_MAX_OUT = 2
SPLIT_MAX_IN = 16


def split_depthwise_applies(conv: nn.Conv2d, x: Tensor) -> bool:
    """Whether a Fast GhostConv block's group ``conv`` runs :func:`split_depthwise_point` on ``x``: CPU
    inference mode, a plain stride-1 zero-padded group conv (not depth-wise) of thin groups on a narrow
    input."""
    g = conv.groups
    plain = (*conv.stride, *conv.dilation) == (1,) * 4 and conv.padding_mode == "zeros"
    thin = 1 < g < conv.in_channels and conv.out_channels // g <= SPLIT_MAX_OUT
    return (x.device.type == "cpu" and torch.is_inference_mode_enabled() and plain and thin
            and conv.in_channels <= SPLIT_MAX_IN)


def split_depthwise_point(group: nn.Conv2d, point: nn.Conv2d, x: Tensor) -> Tensor:
    """``point(group(x))`` for a stride-1 zero-padded group conv followed by a 1x1 conv, computed per output
    ``o`` of a group as a depth-wise conv of ``x`` (input channel ``c`` of group ``j`` with the kernel
    ``group.weight[j, o, c]``) and a 1x1 conv of that whose weight repeats ``point``'s column for ``(j, o)``
    over the group's inputs, which sums them; the ``cout_g`` results are added in place. Same function: the
    group conv's bias moves into ``point``'s. Same MACs in the depth-wise convs as in the group conv."""
    g = group.groups
    cout, cin_g, kh, kw = group.weight.shape
    cout_g, cin = cout // g, cin_g * g
    depthwise = group.weight.view(g, cout_g, cin_g, kh, kw).transpose(0, 1).reshape(cout_g, cin, 1, kh, kw)
    mix = point.weight.view(-1, g, cout_g, 1)
    bias = torch.mv(point.weight.view(-1, cout), group.bias) if group.bias is not None else None
    if point.bias is not None:
        bias = point.bias if bias is None else bias + point.bias

    def part(o: int, b: Tensor | None) -> Tensor:
        y = F.conv2d(x, depthwise[o], padding=group.padding, groups=cin)
        return F.conv2d(y, mix[:, :, o].expand(-1, g, cin_g).reshape(-1, cin, 1, 1), b)

    out = part(0, bias)
    for o in range(1, cout_g):
        out.add_(part(o, None))
    return out


def grouped_conv(conv: nn.Conv2d, x: Tensor) -> Tensor:
    """``conv(x)``; when training on the CPU a grouped ``conv`` runs dense with a block-diagonal weight; under
    ``torch.inference_mode`` on the CPU a group conv (not depth-wise) runs :func:`lane_filled_conv`. Plain
    ``no_grad`` runs ``conv`` itself, so ``FlopCounterMode`` on a CPU forward (mcd.complexity) counts the
    block's true MACs."""
    g = conv.groups
    if g == 1 or x.device.type != "cpu":
        return conv(x)
    if torch.is_inference_mode_enabled():
        plain = (*conv.stride, *conv.dilation) == (1,) * 4 and conv.padding_mode == "zeros"
        if g == conv.in_channels or not plain:
            return conv(x)
        cout, cin_g, _, kw = conv.weight.shape
        return lane_filled_conv(conv, x, lane_stride(cin_g, cout // g, kw))
    if not torch.is_grad_enabled():
        return conv(x)
    cout, cin_g = conv.weight.shape[:2]
    mask = torch.block_diag(*[x.new_ones(cout // g, cin_g) for _ in range(g)])[:, :, None, None]
    return F.conv2d(x, conv.weight.repeat(1, g, 1, 1) * mask, conv.bias, padding=conv.padding)

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
layer by :func:`lane_stride`'s cost model. Inputs (or parts of an input) of at most :data:`SPLIT_MAX_IN`
channels whose groups have at most :data:`SPLIT_MAX_OUT` outputs instead run :func:`split_depthwise`: one
depth-wise convolution per output of a group (oneDNN vectorises those over the input channels) with the
point-wise convolution folded in, which sums over each group's inputs. A block given its input in parts
(:meth:`FastGhostConv.forward_parts`: a U-Net decoder block's upsampled features and skip) runs each part's
groups on the part itself, without the concatenation (:func:`group_then_point`).

The group convolution's output width is not given by the paper; it is ``mid_ratio * cout`` (default 0.5),
which makes the block cheaper than the 3x3 block it replaces, as the paper's component table requires (rows
E, G, H, L lose params and MACs against D, C, J, B). Groups fall back to ``gcd(groups, cin, mid)`` when
``groups`` does not divide both widths (e.g. an input layer of 12 channels with groups 8).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

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
        return self.forward_parts([x])

    def forward_parts(self, parts: Sequence[Tensor]) -> Tensor:
        """The block on ``torch.cat(parts, 1)``. CPU inference (:func:`fast_path_applies`) runs
        :func:`group_then_point`, which concatenates the parts only where the group conv's groups straddle
        them (docs/inference.md; a U-Net decoder block is handed its upsampled features and skip)."""
        if fast_path_applies(self.group, parts):
            primary = group_then_point(self.group, self.point, parts)
        else:
            primary = self.point(grouped_conv(self.group, torch.cat(list(parts), 1) if len(parts) > 1
                                              else parts[0]))
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
    """``conv(x)`` for a stride-1, zero-padded group ``conv``, computed by :func:`lane_filled`."""
    return lane_filled(x, conv.weight, conv.bias, conv.groups, conv.padding, stride)


def lane_filled(x: Tensor, weight: Tensor, bias: Tensor | None, groups: int, padding: tuple[int, ...],
                stride: int) -> Tensor:
    """``F.conv2d(x, weight, bias, padding=padding, groups=groups)`` (stride 1, zero padding) as a
    stride-``(1, stride)`` conv with ``stride`` column phases per output channel (see the module docstring).
    ``stride = 1`` is the conv itself."""
    if stride == 1:
        return F.conv2d(x, weight, bias, padding=padding, groups=groups)
    g, s = groups, stride
    cout, cin_g, kh, kw = weight.shape
    cout_g = cout // g
    filled = weight.new_zeros(g, s, cout_g, cin_g, kh, kw + s - 1)
    for phase in range(s):
        filled[:, phase, ..., phase : phase + kw] = weight.reshape(g, cout_g, cin_g, kh, kw)
    bias = None if bias is None else bias.view(g, 1, cout_g).expand(g, s, cout_g).reshape(-1)
    b, _, h, w = x.shape
    wo = -(-w // s)
    if wo * s != w:                              # zero columns on the right; their outputs are cropped
        x = F.pad(x, (0, wo * s - w))
    y = F.conv2d(x, filled.view(g * s * cout_g, cin_g, kh, kw + s - 1), bias, stride=(1, s),
                 padding=padding, groups=g)                                   # [B, (g, phase, o), H, wo]
    y = y.permute(0, 2, 3, 1).reshape(b, h, wo, g, s, cout_g).transpose(3, 4).reshape(b, h, wo * s, cout)
    return y[:, :, :w].permute(0, 3, 1, 2).contiguous(memory_format=torch.channels_last)


#: :func:`group_then_point` splits a part into depth-wise convs where a group has at most this many outputs
#: and the part at most :data:`SPLIT_MAX_IN` channels: the widths where that measured faster than
#: :func:`lane_filled` (docs/inference.md, "Measured: the group convolutions"; oneDNN's depth-wise rate
#: falls for wider inputs).
SPLIT_MAX_OUT = 2
SPLIT_MAX_IN = 16


def fast_path_applies(conv: nn.Conv2d, parts: Sequence[Tensor]) -> bool:
    """Whether a Fast GhostConv block's group ``conv`` runs :func:`group_then_point` on ``parts``: CPU
    inference mode and a plain stride-1 zero-padded group conv (not dense, not depth-wise). Plain
    ``no_grad`` keeps the grouped conv, so ``FlopCounterMode`` counts the true MACs."""
    g = conv.groups
    plain = (*conv.stride, *conv.dilation) == (1,) * 4 and conv.padding_mode == "zeros"
    return (all(p.device.type == "cpu" for p in parts) and torch.is_inference_mode_enabled() and plain
            and 1 < g < conv.in_channels)


def splits(cin: int, cout_g: int) -> bool:
    """Whether :func:`group_then_point` runs a part of ``cin`` channels whose groups have ``cout_g`` outputs
    as :func:`split_depthwise` (else :func:`lane_filled` and the point-wise conv)."""
    return cin <= SPLIT_MAX_IN and cout_g <= SPLIT_MAX_OUT


def group_then_point(group: nn.Conv2d, point: nn.Conv2d, parts: Sequence[Tensor]) -> Tensor:
    """``point(group(torch.cat(parts, 1)))`` for a stride-1 zero-padded group conv and a 1x1 conv: per part
    (the parts are concatenated first only where a group straddles two of them), the part's groups as
    :func:`split_depthwise` where :func:`splits` holds, else as :func:`lane_filled` followed by the columns
    of ``point`` that read them; the parts' results are added in place. Same function and MACs."""
    g = group.groups
    cout, cin_g, _, kw = group.weight.shape
    cout_g = cout // g
    if any(p.shape[1] % cin_g for p in parts):
        parts = [torch.cat(list(parts), 1)]
    out: Tensor | None = None
    j = 0                                                             # first group of the part
    for part in parts:
        gp = part.shape[1] // cin_g
        rows = slice(j * cout_g, (j + gp) * cout_g)
        weight, pw = group.weight[rows], point.weight[:, rows]
        bias = None if group.bias is None else group.bias[rows]
        pb = point.bias if out is None else None
        if splits(part.shape[1], cout_g):
            y = split_depthwise(part, weight, bias, gp, group.padding, pw, pb)
        else:
            y = F.conv2d(lane_filled(part, weight, bias, gp, group.padding, lane_stride(cin_g, cout_g, kw)),
                         pw, pb)
        out = y if out is None else out.add_(y)
        j += gp
    if out is None or j != g:
        raise ValueError(f"group_then_point: the parts have {[p.shape[1] for p in parts]} channels; the "
                         f"group conv reads {g * cin_g}")
    return out


def split_depthwise_point(group: nn.Conv2d, point: nn.Conv2d, x: Tensor) -> Tensor:
    """``point(group(x))`` computed by :func:`split_depthwise`."""
    return split_depthwise(x, group.weight, group.bias, group.groups, group.padding, point.weight, point.bias)


def split_depthwise(x: Tensor, weight: Tensor, bias: Tensor | None, groups: int, padding: tuple[int, ...],
                    point_weight: Tensor, point_bias: Tensor | None) -> Tensor:
    """A stride-1 zero-padded group conv (``weight``, ``bias``, ``groups``) followed by a 1x1 conv
    (``point_weight``, ``point_bias``), computed per output ``o`` of a group as a depth-wise conv of ``x``
    (input channel ``c`` of group ``j`` with the kernel ``weight[j, o, c]``; oneDNN vectorises it over the
    input channels, so no lane is empty) and a 1x1 conv of that whose weight repeats the point-wise column of
    ``(j, o)`` over the group's inputs, which sums them; the results are added in place. Same function: the
    group conv's bias moves into the point-wise bias. Same MACs in the depth-wise convs as in the group
    conv."""
    g = groups
    cout, cin_g, kh, kw = weight.shape
    cout_g, cin = cout // g, cin_g * g
    depthwise = weight.reshape(g, cout_g, cin_g, kh, kw).transpose(0, 1).reshape(cout_g, cin, 1, kh, kw)
    mix = point_weight.reshape(-1, g, cout_g, 1)
    folded = torch.mv(point_weight.reshape(-1, cout), bias) if bias is not None else None
    if point_bias is not None:
        folded = point_bias if folded is None else folded + point_bias

    def part(o: int, b: Tensor | None) -> Tensor:
        y = F.conv2d(x, depthwise[o], padding=padding, groups=cin)
        return F.conv2d(y, mix[:, :, o].expand(-1, g, cin_g).reshape(-1, cin, 1, 1), b)

    out = part(0, folded)
    for o in range(1, cout_g):
        out.add_(part(o, None))
    return out


def grouped_conv(conv: nn.Conv2d, x: Tensor) -> Tensor:
    """``conv(x)``; when training on the CPU a grouped ``conv`` runs dense with a block-diagonal weight.
    Without gradients it is ``conv`` itself (CPU inference mode runs :func:`group_then_point` instead, from
    :class:`FastGhostConv`), so ``FlopCounterMode`` on a CPU forward (mcd.complexity) counts the block's true
    MACs."""
    g = conv.groups
    if g == 1 or x.device.type != "cpu" or not torch.is_grad_enabled():
        return conv(x)
    cout, cin_g = conv.weight.shape[:2]
    mask = torch.block_diag(*[x.new_ones(cout // g, cin_g) for _ in range(g)])[:, :, None, None]
    return F.conv2d(x, conv.weight.repeat(1, g, 1, 1) * mask, conv.bias, padding=conv.padding)

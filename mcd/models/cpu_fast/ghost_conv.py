"""CPU fast paths of the Fast GhostConv block (:class:`mcd.models.ghost_conv.FastGhostConv`): the same
function, computed faster on the CPU (docs/inference.md). ``tests/models/test_inference_paths.py`` checks each
against the plain convolutions.

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
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from mcd.models.cpu_fast import fused_conv
from mcd.models.cpu_fast.replicate import padded_conv, replicate_pad, replicate_padded
from mcd.models.inputs import cat_channels, with_constant


def primary_and_ghost(group: nn.Conv2d, point: nn.Conv2d, ghost: nn.Conv2d, parts: Sequence[Tensor],
                      constant: Tensor | None = None) -> Tensor:
    """``relu(cat([p, ghost(p)]))`` with ``p = point(group(x))``, the whole Fast GhostConv block, without a
    concatenation or a ReLU pass of its own: :func:`group_then_point` runs the point-wise conv with its
    weight stacked twice, so it writes ``[p, p]``, and one depth-wise 3x3 conv over both halves, its ReLU
    fused (:mod:`mcd.models.cpu_fast.fused_conv`), applies an identity kernel (the centre tap 1, no bias) to
    the first half and the ghost conv to the second. Same function: the identity passes ``p`` through exactly.
    Costs ``mid x half`` more MACs in the point-wise conv and ``9 x half`` in the depth-wise one per pixel,
    where the block's MACs are counted on its own form. CPU inference, where :func:`fused_conv.applies`."""
    pw, pb = point.weight, point.bias
    both = group_then_point(group, torch.cat([pw, pw]), None if pb is None else torch.cat([pb, pb]), parts,
                            constant)
    half = ghost.out_channels
    identity = torch.zeros_like(ghost.weight)
    identity[:, :, ghost.kernel_size[0] // 2, ghost.kernel_size[1] // 2] = 1
    bias = None if ghost.bias is None else torch.cat([torch.zeros_like(ghost.bias), ghost.bias])
    return fused_conv.conv2d(both, torch.cat([identity, ghost.weight]), bias, ghost.padding, groups=2 * half,
                             relu=True)


def merged_weight(group: nn.Conv2d, point: nn.Conv2d) -> tuple[Tensor, Tensor | None]:
    """``point(group(x))``, a group conv then a 1x1 conv, as one dense conv: its weight ``[half, cin, k, k]``
    (each output's point-wise column times the group conv's kernels, per group) and bias (the point-wise bias
    plus the point-wise conv of the group conv's bias). Same function (linear maps compose; the padding is
    the group conv's). Differentiable in both convs' parameters."""
    g = group.groups
    mid, cin_g, kh, kw = group.weight.shape
    pw = point.weight.reshape(point.out_channels, g, mid // g)
    weight = torch.einsum("ogm,gmcyx->ogcyx", pw, group.weight.reshape(g, mid // g, cin_g, kh, kw))
    bias = point.bias
    if group.bias is not None:
        folded = point.weight.reshape(point.out_channels, mid) @ group.bias
        bias = folded if bias is None else bias + folded
    return weight.reshape(point.out_channels, g * cin_g, kh, kw), bias


def merged_pays(group: nn.Conv2d, half: int, dtype: torch.dtype) -> bool:
    """Whether :func:`merged_weight`'s dense conv runs faster than the group conv and the point-wise conv,
    by a model of oneDNN's blocking: a conv costs ``ceil(outputs / 16) * 16 x ceil(inputs / K) * K`` per
    group and tap, with ``K = 32`` where bf16 runs on AMX tiles (32 bf16 inputs per tile row; the dense conv
    has ``groups`` times the MACs but fills the tiles that a group's few inputs and outputs leave empty) and
    ``K = 1`` elsewhere (fp32 and AVX-512 bf16, where the dense conv only adds MACs). Measured per block of
    ``F_s`` in notes/f_speed.md."""
    amx = dtype == torch.bfloat16 and bool(getattr(torch.cpu, "_is_amx_tile_supported", lambda: False)())
    k = 32 if amx else 1

    def cost(outputs: int, inputs: int) -> int:
        return -(-outputs // LANES) * LANES * -(-inputs // k) * k

    g = group.groups
    grouped = g * cost(group.out_channels // g, group.in_channels // g)
    dense = cost(half, group.in_channels)
    return dense <= grouped if amx else dense < grouped


def replicate_block(group: nn.Conv2d, point: nn.Conv2d, ghost: nn.Conv2d, parts: Sequence[Tensor],
                    constant: Tensor | None = None) -> Tensor:
    """The Fast GhostConv block ``relu(cat([p, ghost(p)]))``, ``p = point(group(x))``, with ``replicate``
    padding, for CPU inference (docs/inference.md "Replicate padding"). ``x`` (the parts and the constant
    channels) is replicate-padded once into one channels-last tensor (:func:`replicate_padded`: the
    concatenation costs nothing more), ``p`` is computed on it with no padding, either as the dense conv of
    :func:`merged_weight` where :func:`merged_pays` says so or by :func:`group_then_point`, and the ghost runs
    as in :func:`primary_and_ghost` (identity and ghost kernels, ReLU fused) on ``[p, p]`` replicate-padded
    by one write. Constant channels are constant over the padded image too: with one image they fold into
    the dense conv's bias. Same function as ``nn.Conv2d(padding_mode="replicate")``, which pads each conv's
    input with ``F.pad`` and runs the plain grouped conv."""
    dtype = fused_conv.compute_dtype(group.weight)
    half = ghost.out_channels
    variable = sum(p.shape[1] for p in parts)
    if merged_pays(group, half, dtype):
        weight, bias = merged_weight(group, point)
        fold = constant is not None and parts[0].shape[0] == 1
        if fold:
            inside = weight[:, variable:].sum((-2, -1)) @ constant[0].to(weight.dtype)
            bias = inside if bias is None else bias + inside
            weight = weight[:, :variable]
        x = replicate_padded(parts, group.padding, dtype, None if fold else constant)
        primary = fused_conv.conv2d(x, weight, bias)
    else:
        x = replicate_padded(parts, group.padding, dtype)
        primary = group_then_point(group, point.weight, point.bias, [x], constant, padding=(0, 0))
    both = replicate_padded([primary, primary], ghost.padding, primary.dtype)
    identity = torch.zeros_like(ghost.weight)
    identity[:, :, ghost.kernel_size[0] // 2, ghost.kernel_size[1] // 2] = 1
    bias = None if ghost.bias is None else torch.cat([torch.zeros_like(ghost.bias), ghost.bias])
    return fused_conv.conv2d(both, torch.cat([identity, ghost.weight]), bias, groups=2 * half, relu=True)


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
    b, _, h_in, w_in = x.shape
    h, w = h_in + 2 * padding[0] - kh + 1, w_in + 2 * padding[1] - kw + 1                  # output size
    wo = -(-w // s)
    need = wo * s + kw - 1 - 2 * padding[1]      # input columns for wo * s outputs
    if need != w_in:                             # zero columns on the right; their outputs are cropped
        x = F.pad(x, (0, need - w_in))
    y = F.conv2d(x, filled.view(g * s * cout_g, cin_g, kh, kw + s - 1), bias, stride=(1, s),
                 padding=padding, groups=g)                                   # [B, (g, phase, o), h, wo]
    y = y.permute(0, 2, 3, 1).reshape(b, h, wo, g, s, cout_g).transpose(3, 4).reshape(b, h, wo * s, cout)
    return y[:, :, :w].permute(0, 3, 1, 2).contiguous(memory_format=torch.channels_last)


#: :func:`group_then_point` splits a part into depth-wise convs where a group has at most this many outputs
#: and the part at most :data:`SPLIT_MAX_IN` channels: the widths where that measured faster than
#: :func:`lane_filled` (reports/bench_1080p/notes.md, "Measured: the group convolutions"; oneDNN's depth-wise
#: rate falls for wider inputs).
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


def group_then_point(group: nn.Conv2d, point_weight: Tensor, point_bias: Tensor | None,
                     parts: Sequence[Tensor], constant: Tensor | None = None,
                     padding: tuple[int, ...] | None = None) -> Tensor:
    """``point(group(x))`` for a stride-1 zero-padded group conv and a 1x1 conv ``point`` (``point_weight``,
    ``point_bias``), where ``x`` is the channel
    concatenation of ``parts`` and, when given, of ``constant`` ``[B, D]`` broadcast over the image (the last
    ``D`` channels). Parts that hold whole groups are runs as they are; where a group straddles two parts they
    are concatenated first (the per-group pieces measured slower for ``F_s``'s 144 -> 24 decoder block),
    unless constant channels share the last group (then :func:`group_runs` cuts the input into the groups'
    pieces so that the constant channels are left out). Each run's groups run as :func:`split_depthwise` where
    :func:`splits` holds, else as :func:`lane_filled` followed by the columns of ``point`` that read them, and
    the runs' results are added in place. Constant channels that share the last group with variable ones are
    not convolved: their part of that group's output is its value inside the image (folded into the bias) plus
    a correction in the ``padding``-wide border (:func:`add_border_correction`). Same function and MACs.
    ``padding`` (default ``group.padding``) is the zero padding; ``(0, 0)`` on parts padded beforehand
    (:func:`replicate_block`)."""
    padding = group.padding if padding is None else padding
    g = group.groups
    cout, cin_g, _, kw = group.weight.shape
    cout_g = cout // g
    variable = sum(p.shape[1] for p in parts)
    depth = 0 if constant is None else constant.shape[1]
    if variable + depth != g * cin_g:
        raise ValueError(f"group_then_point: the parts have {[p.shape[1] for p in parts]} channels and the "
                         f"constant {depth}; the group conv reads {g * cin_g}")
    if constant is not None and (variable % cin_g == 0 or depth >= cin_g):       # not in a shared group
        return group_then_point(group, point_weight, point_bias, with_constant(parts, constant),
                                padding=padding)
    if constant is None and len(parts) > 1 and any(p.shape[1] % cin_g for p in parts):
        parts = [torch.cat(list(parts), 1)]         # a group straddles two parts: one grouped conv (faster)
    out: Tensor | None = None
    for j, x in group_runs(parts, cin_g):
        n = -(-x.shape[1] // cin_g)
        rows = slice(j * cout_g, (j + n) * cout_g)
        weight, pw = group.weight[rows, : x.shape[1] // n], point_weight[:, rows]
        bias = None if group.bias is None else group.bias[rows]
        pb = point_bias if out is None else None
        if constant is not None and x.shape[1] < n * cin_g:            # the group it shares with the constant
            taps = torch.einsum("bc,ocyx->boyx", constant.float(),
                                group.weight[rows, x.shape[1]:].float())                # [B, cout_g, kh, kw]
            inside = taps.sum((-2, -1))
            single = x.shape[0] == 1
            if single:
                bias = inside[0] if bias is None else bias + inside[0]
            y = lane_filled(x, weight, bias, n, padding, lane_stride(x.shape[1], cout_g, kw))
            if not single:
                y.add_(inside[:, :, None, None].to(y.dtype))
            add_border_correction(y, taps, padding)
            out = point_into(y, pw, pb, out)
        elif splits(x.shape[1], cout_g):
            out = split_depthwise(x, weight, bias, n, padding, pw, pb, out)
        else:
            y = lane_filled(x, weight, bias, n, padding, lane_stride(cin_g, cout_g, kw))
            out = point_into(y, pw, pb, out)
    if out is None:
        raise ValueError("group_then_point needs at least one part")
    return out


def group_runs(parts: Sequence[Tensor], cin_g: int) -> list[tuple[int, Tensor]]:
    """``(first group, input)`` runs covering the channel concatenation of ``parts`` for a group conv with
    ``cin_g`` inputs per group: a part that starts at a group boundary and holds whole groups is a run as it
    is (no copy); other parts are cut at the group boundaries and the pieces of each group concatenated. The
    last run may end inside a group (its remaining inputs are constant channels)."""
    runs: list[tuple[int, Tensor]] = []
    pending: list[Tensor] = []
    start = 0                                                  # channel where the pending pieces start

    def emit() -> None:
        runs.append((start // cin_g, pending[0] if len(pending) == 1 else cat_channels(pending)))
        pending.clear()

    for part in parts:
        c = part.shape[1]
        if not pending and start % cin_g == 0 and c % cin_g == 0:
            runs.append((start // cin_g, part))
            start += c
            continue
        offset = 0
        while offset < c:
            first = start + sum(q.shape[1] for q in pending)
            take = min(c - offset, cin_g - first % cin_g)
            pending.append(part[:, offset : offset + take])
            offset += take
            if (first + take) % cin_g == 0:
                emit()
                start = first + take
    if pending:
        emit()
    return runs


def add_border_correction(y: Tensor, taps: Tensor, padding: tuple[int, ...]) -> None:
    """Add to ``y`` ``[B, O, H, W]`` (in place) the difference, in the ``padding``-wide border, between a
    zero-padded convolution of a constant image and its value inside the image: ``taps`` ``[B, O, kh, kw]``
    is the kernel already summed against the constant; inside, every tap counts, at the border only those
    that land in the image."""
    h, w = y.shape[-2:]
    kh, kw = taps.shape[-2:]
    ph, pw = padding[0], padding[1]
    inside = taps.sum((-2, -1))[:, :, None, None]

    def valid(n: int, k: int, p: int) -> Tensor:                             # [n, k]: tap in the image
        at = torch.arange(n, device=taps.device)[:, None] + torch.arange(k, device=taps.device) - p
        return ((at >= 0) & (at < n)).to(taps.dtype)

    vy, vx = valid(h, kh, ph), valid(w, kw, pw)

    def fix(ys: slice, xs: slice) -> None:
        if ys.start < ys.stop and xs.start < xs.stop:
            fixed = torch.einsum("boij,yi,xj->boyx", taps, vy[ys], vx[xs]) - inside
            y[:, :, ys, xs] += fixed.to(y.dtype)

    top = slice(0, min(ph, h))
    bottom = slice(max(h - ph, top.stop), h)
    left = slice(0, min(pw, w))
    right = slice(max(w - pw, left.stop), w)
    fix(top, slice(0, w))
    fix(bottom, slice(0, w))
    fix(slice(top.stop, bottom.start), left)
    fix(slice(top.stop, bottom.start), right)


def point_into(y: Tensor, weight: Tensor, bias: Tensor | None, out: Tensor | None) -> Tensor:
    """The 1x1 conv ``F.conv2d(y, weight, bias)``, added in place to ``out`` when given (returned); in CPU
    inference the add is a post-op of the conv (:mod:`mcd.models.cpu_fast.fused_conv`)."""
    if fused_conv.applies(weight, [y]):
        return fused_conv.conv2d(y, weight, bias, add_to=out)
    z = F.conv2d(y, weight, bias)
    return z if out is None else out.add_(z)


def split_depthwise(x: Tensor, weight: Tensor, bias: Tensor | None, groups: int, padding: tuple[int, ...],
                    point_weight: Tensor, point_bias: Tensor | None, out: Tensor | None = None) -> Tensor:
    """A stride-1 zero-padded group conv (``weight``, ``bias``, ``groups``) followed by a 1x1 conv
    (``point_weight``, ``point_bias``), computed per output ``o`` of a group as a depth-wise conv of ``x``
    (input channel ``c`` of group ``j`` with the kernel ``weight[j, o, c]``; oneDNN vectorises it over the
    input channels, so no lane is empty) and a 1x1 conv of that whose weight repeats the point-wise column of
    ``(j, o)`` over the group's inputs, which sums them; the results are added in place (to ``out`` too,
    when given: :func:`point_into`). Same function: the group conv's bias moves into the point-wise bias.
    Same MACs in the depth-wise convs as in the group conv."""
    g = groups
    cout, cin_g, kh, kw = weight.shape
    cout_g, cin = cout // g, cin_g * g
    depthwise = weight.reshape(g, cout_g, cin_g, kh, kw).transpose(0, 1).reshape(cout_g, cin, 1, kh, kw)
    mix = point_weight.reshape(-1, g, cout_g, 1)
    folded = torch.mv(point_weight.reshape(-1, cout), bias) if bias is not None else None
    if point_bias is not None:
        folded = point_bias if folded is None else folded + point_bias

    def part(o: int, b: Tensor | None, into: Tensor | None) -> Tensor:
        y = F.conv2d(x, depthwise[o], padding=padding, groups=cin)
        return point_into(y, mix[:, :, o].expand(-1, g, cin_g).reshape(-1, cin, 1, 1), b, into)

    out = part(0, folded, out)
    for o in range(1, cout_g):
        part(o, None, out)
    return out


def replicate_path_applies(group: nn.Conv2d, ghost: nn.Conv2d, parts: Sequence[Tensor]) -> bool:
    """Whether a Fast GhostConv block runs :func:`replicate_block`: CPU inference (fused operators available:
    :func:`fused_conv.applies`), ``replicate`` padding and a plain stride-1 group conv (not dense, not
    depth-wise)."""
    plain = (*group.stride, *group.dilation, *ghost.stride, *ghost.dilation) == (1,) * 8
    return (group.padding_mode == ghost.padding_mode == "replicate" and plain
            and 1 < group.groups < group.in_channels and fused_conv.applies(ghost.weight, parts))


def merged_primary(group: nn.Conv2d, point: nn.Conv2d, x: Tensor) -> Tensor:
    """``point(group(x))`` as the one dense conv of :func:`merged_weight`, for CPU training: autograd reaches
    both convs' parameters through the merged weight. The grouped conv trained on the CPU already runs dense
    (:func:`grouped_conv`, same MACs), so this drops the point-wise conv and its ``[B, mid, H, W]`` tensor
    from the forward and the backward. Padding as ``group``'s (``F.pad`` first where it is not zeros, as
    ``nn.Conv2d`` does)."""
    weight, bias = merged_weight(group, point)
    padding = group.padding
    if group.padding_mode != "zeros":
        ph, pw = group.padding
        x, padding = replicate_pad(x, (pw, pw, ph, ph)), (0, 0)
    return F.conv2d(x, weight, bias, padding=padding)


def merged_applies(group: nn.Conv2d, x: Tensor) -> bool:
    """Whether a Fast GhostConv block runs :func:`merged_primary`: CPU training (gradients on, not inference
    mode; plain ``no_grad`` keeps the grouped conv, so ``FlopCounterMode`` counts the block's true MACs) of a
    stride-1 group conv."""
    plain = (*group.stride, *group.dilation) == (1,) * 4
    return (x.device.type == "cpu" and torch.is_grad_enabled() and not torch.is_inference_mode_enabled()
            and plain and group.groups > 1)


def grouped_conv(conv: nn.Conv2d, x: Tensor) -> Tensor:
    """``conv(x)``; when training on the CPU a grouped ``conv`` runs dense with a block-diagonal weight.
    Without gradients it is ``conv`` itself (CPU inference mode runs :func:`group_then_point` instead, from
    :class:`FastGhostConv`), so ``FlopCounterMode`` on a CPU forward (mcd.models.complexity) counts the
    block's true MACs."""
    g = conv.groups
    if g == 1 or x.device.type != "cpu" or not torch.is_grad_enabled():
        return padded_conv(conv, x)
    cout, cin_g = conv.weight.shape[:2]
    mask = torch.block_diag(*[x.new_ones(cout // g, cin_g) for _ in range(g)])[:, :, None, None]
    padding = conv.padding
    if conv.padding_mode != "zeros":  # replicate: pad first, as nn.Conv2d does
        ph, pw = conv.padding
        x, padding = replicate_pad(x, (pw, pw, ph, ph)), 0
    return F.conv2d(x, conv.weight.repeat(1, g, 1, 1) * mask, conv.bias, padding=padding)

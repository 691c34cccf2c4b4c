"""Replicate padding for CPU inference (docs/inference.md "Replicate padding"): ``F.pad(mode="replicate")``
of a channels-last tensor measured several times slower than writing the same padded tensor by slices
(notes/f_speed.md), and ``nn.Conv2d(padding_mode="replicate")`` calls it on every input.
:func:`replicate_padded` writes the padded tensor (of several parts, and of constant channels, at once: the
Fast GhostConv blocks, :mod:`mcd.models.cpu_fast.ghost_conv`); :func:`replicate_conv` runs a
replicate-padded convolution on it (the kernel-map head's last convolution,
:class:`mcd.models.kernel_pool.KernelMapHead`). Tested against the plain operations in
``tests/models/test_fast_paths.py``.

In training, :func:`replicate_pad` and :func:`padded_conv` pad a convolution's input as ``F.pad`` does, but
in the input's own dtype: under CPU autocast ``F.pad`` is one of autocast's fp32 operations, so a bf16 input
was cast to fp32, padded, and the padded tensor cast back to bf16 by the convolution, three copies where one
does (notes/f_speed.md "The training step"). The values the convolution reads are the same. The gradient is
``F.pad``'s: ATen's own backward kernel, in the dtype ``F.pad`` would have padded in, handed the gradient in
the input's memory layout (the kernel adds each input pixel's contributions in the same order in either
layout, and ran 3-7x slower on a channels-last input's gradient in the plain layout), then cast to the
input's dtype as autocast's cast node does. Bit for bit ``F.pad``'s: ``tests/models/test_fast_paths.py``.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from mcd.models import fast_paths
from mcd.models.cpu_fast import fused_conv
from mcd.models.cpu_fast.layout import memory_format


def replicate_padded(parts: Sequence[Tensor], padding: Sequence[int], dtype: torch.dtype,
                     constant: Tensor | None = None) -> Tensor:
    """The channel concatenation of ``parts`` (and of ``constant`` ``[B, D]`` broadcast over the image, when
    given), replicate-padded by ``padding`` ``(ph, pw)``, in ``dtype``: one channels-last tensor, each value
    written once (the parts into its interior, then the top and bottom rows, then the left and right columns
    with the corners). ``F.pad(mode="replicate")`` makes the same tensor per part and measured several times
    slower on channels-last inputs (docs/inference.md "Replicate padding"). No gradient: CPU inference."""
    ph, pw = int(padding[0]), int(padding[1])
    b, _, h, w = parts[0].shape
    depth = 0 if constant is None else constant.shape[1]
    channels = sum(p.shape[1] for p in parts) + depth
    y = torch.empty(b, channels, h + 2 * ph, w + 2 * pw, dtype=dtype, device=parts[0].device,
                    memory_format=torch.channels_last)
    start = 0
    for part in parts:
        y[:, start : start + part.shape[1], ph : ph + h, pw : pw + w] = part
        start += part.shape[1]
    if constant is not None:                                   # constant over the image, so over its border
        y[:, start:] = constant[:, :, None, None]
    inner = slice(pw, pw + w)
    if ph:
        y[:, :start, :ph, inner] = y[:, :start, ph : ph + 1, inner]
        y[:, :start, ph + h :, inner] = y[:, :start, ph + h - 1 : ph + h, inner]
    if pw:
        y[:, :start, :, :pw] = y[:, :start, :, pw : pw + 1]
        y[:, :start, :, pw + w :] = y[:, :start, :, pw + w - 1 : pw + w]
    return y


def replicate_conv_applies(conv: nn.Conv2d, x: Tensor) -> bool:
    """Whether :func:`replicate_conv` runs ``conv(x)``: a stride-1, undilated ``conv`` padded with
    ``replicate``, where the fused operators apply (CPU inference: :func:`fused_conv.applies`)."""
    plain = (*conv.stride, *conv.dilation) == (1,) * 4
    return conv.padding_mode == "replicate" and plain and fused_conv.applies(conv.weight, [x])


def replicate_conv(conv: nn.Conv2d, x: Tensor) -> Tensor:
    """``conv(x)`` for a replicate-padded ``conv`` (where :func:`replicate_conv_applies`): ``x`` padded once
    by :func:`replicate_padded` in the conv's compute dtype, then the conv with no padding. Same function as
    ``nn.Conv2d``'s ``F.pad`` and conv."""
    padded = replicate_padded([x], conv.padding, fused_conv.compute_dtype(conv.weight))
    return fused_conv.conv2d(padded, conv.weight, conv.bias, groups=conv.groups)


class ReplicatePad(torch.autograd.Function):
    """``F.pad(x, padding, mode="replicate")`` for a convolution to read, in ``x``'s dtype, with the gradient
    of ``F.pad`` under the autocast state of its forward (module docstring)."""

    @staticmethod
    def forward(ctx, x: Tensor, padding: tuple[int, int, int, int]) -> Tensor:  # noqa: ANN001
        ctx.padding, ctx.shape, ctx.dtype, ctx.sum_dtype = list(padding), x.shape, x.dtype, pad_dtype(x)
        ctx.layout = memory_format(x)
        with torch.autocast(x.device.type, enabled=False):
            return F.pad(x, padding, mode="replicate")

    @staticmethod
    def backward(ctx, grad: Tensor) -> tuple[Tensor, None]:  # noqa: ANN001
        if ring_sums_apply(grad, ctx.shape, ctx.padding, ctx.dtype):
            return ring_sums(grad, ctx.shape, ctx.padding, ctx.sum_dtype, ctx.layout), None
        like = torch.empty(ctx.shape, dtype=ctx.sum_dtype, device=grad.device, memory_format=ctx.layout)
        grad = grad.to(dtype=ctx.sum_dtype, memory_format=ctx.layout)
        summed = torch.ops.aten.replication_pad2d_backward(grad, like, ctx.padding)  # reads like's shape
        return summed.to(ctx.dtype), None


def ring_sums_apply(grad: Tensor, shape: Sequence[int], padding: Sequence[int], dtype: torch.dtype) -> bool:
    """Whether :func:`ring_sums` computes the gradient: the same padding on opposite sides, an input of at
    least 2 x 2 pixels, and the gradient in the input's dtype."""
    left, right, top, bottom = padding
    return left == right >= 0 and top == bottom >= 0 and min(shape[-2:]) >= 2 and grad.dtype == dtype


def ring_sums(grad: Tensor, shape: Sequence[int], padding: Sequence[int], sum_dtype: torch.dtype,
              layout: torch.memory_format) -> Tensor:
    """The gradient of ``F.pad(x, padding, mode="replicate")`` for the padded tensor's gradient ``grad``
    (where :func:`ring_sums_apply`), the numbers of ATen's backward kernel in ``sum_dtype`` cast to
    ``grad``'s dtype, computed on the input's outer ring only. The kernel adds the padded tensor's
    gradient, in the padded tensor's row-major order, into a zero-filled gradient: a pixel inside the ring
    receives one value (``0 + g``, which is ``g`` but for a negative zero, in any dtype), a pixel of the ring
    the values of its padding too, in that order. Those sums are made here in the same order, in
    ``sum_dtype``, on the ring's few pixels, and the inside is one copy (``g + 0``) in ``grad``'s dtype."""
    pw, ph = padding[0], padding[2]
    h, w = shape[-2:]
    out = torch.empty(shape, dtype=grad.dtype, device=grad.device, memory_format=layout)
    torch.add(grad[..., ph : ph + h, pw : pw + w], 0.0, out=out)

    def ordered_sum(terms: Tensor) -> Tensor:
        """``0 + t_0 + t_1 + ...`` over the last axis of ``terms``, in ``sum_dtype``, one add at a time."""
        acc = terms[..., 0].to(sum_dtype) + 0.0
        for k in range(1, terms.shape[-1]):
            acc += terms[..., k]
        return acc.to(grad.dtype)

    rows = grad[..., : ph + 1, :], grad[..., h - 1 + ph :, :]              # top and bottom: [.., ph + 1, W']
    for i, block in zip((0, h - 1), rows, strict=True):
        out[..., i, 1 : w - 1] = ordered_sum(block[..., pw + 1 : pw + w - 1].transpose(-1, -2))
    cols = grad[..., ph + 1 : ph + h - 1, : pw + 1], grad[..., ph + 1 : ph + h - 1, w - 1 + pw :]
    for j, block in zip((0, w - 1), cols, strict=True):
        out[..., 1 : h - 1, j] = ordered_sum(block)
    corners = [block[..., :pw + 1] if j == 0 else block[..., w - 1 + pw :] for block in rows for j in (0, 1)]
    sums = ordered_sum(torch.stack(corners, -1).flatten(-3, -2).transpose(-1, -2))   # [.., 4], row-major
    for k, (i, j) in enumerate(((0, 0), (0, w - 1), (h - 1, 0), (h - 1, w - 1))):
        out[..., i, j] = sums[..., k]
    return out


def pad_dtype(x: Tensor) -> torch.dtype:
    """The dtype ``F.pad(x, mode="replicate")`` pads ``x`` in: fp32 for a bf16 or fp16 ``x`` under autocast
    (an fp32 operation of autocast's), else ``x``'s."""
    low = x.dtype in (torch.bfloat16, torch.float16)
    return torch.float32 if low and torch.is_autocast_enabled(x.device.type) else x.dtype


def replicate_pad(x: Tensor, padding: Sequence[int]) -> Tensor:
    """``F.pad(x, padding, mode="replicate")`` (``padding`` ``(left, right, top, bottom)``) of a 4-D ``x``
    that a convolution reads next. Fast path (:mod:`mcd.models.fast_paths`): the copy is made in ``x``'s own
    dtype, not in autocast's fp32 (the convolution would cast the fp32 copy back: the values it reads are the
    same, and a cast of ``x`` and one of the padded tensor are saved), and where a gradient of ``x`` is
    taken, through :class:`ReplicatePad`."""
    pad = tuple(int(p) for p in padding)
    if not (fast_paths.enabled() and x.dim() == 4 and x.device.type in AUTOCAST_DEVICES):
        return F.pad(x, pad, mode="replicate")  # e.g. the meta device of the MAC count: no autocast there
    if x.requires_grad and torch.is_grad_enabled():
        return ReplicatePad.apply(x, pad)
    with torch.autocast(x.device.type, enabled=False):
        return F.pad(x, pad, mode="replicate")


#: The devices whose autocast state :func:`replicate_pad` reads (`torch.is_autocast_enabled` refuses others)
AUTOCAST_DEVICES = ("cpu", "cuda")


def padded_conv(conv: nn.Conv2d, x: Tensor) -> Tensor:
    """``conv(x)``; a ``replicate``-padded ``conv`` pads through :func:`replicate_pad` and convolves as
    ``nn.Conv2d`` does after its ``F.pad`` (no padding, the conv's stride, dilation and groups)."""
    if conv.padding_mode != "replicate":
        return conv(x)
    ph, pw = conv.padding  # type: ignore[misc]
    return F.conv2d(replicate_pad(x, (pw, pw, ph, ph)), conv.weight, conv.bias, conv.stride, 0, conv.dilation,
                    conv.groups)

"""Replicate padding for CPU inference (docs/inference.md "Replicate padding"): ``F.pad(mode="replicate")``
of a channels-last tensor measured several times slower than writing the same padded tensor by slices
(notes/f_speed.md), and ``nn.Conv2d(padding_mode="replicate")`` calls it on every input.
:func:`replicate_padded` writes the padded tensor (of several parts, and of constant channels, at once: the
Fast GhostConv blocks, :mod:`mcd.models.cpu_fast.ghost_conv`); :func:`replicate_conv` runs a
replicate-padded convolution on it (the kernel-map head's last convolution,
:class:`mcd.models.kernel_pool.KernelMapHead`). Tested against the plain operations in
``tests/models/test_fast_paths.py``.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import Tensor, nn

from mcd.models.cpu_fast import fused_conv


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

"""Bilinear upsampling whose backward reads its gradient in channels-last (notes/f_speed.md "The training
step"; the U-Net decoders of ``F_s`` and ``F_d``, :class:`mcd.models.unet.UNet`).

A decoder level upsamples its input and concatenates the skip, so the upsampled tensor's gradient reaches
ATen's ``upsample_bilinear2d_backward`` as a channel slice of the concatenation's gradient, or (``F_s``'s
levels, whose tensors are in the plain layout in training) as a plain tensor. The CPU kernel ran 4-8x slower
on those than on a channels-last gradient, both layout conversions included (notes/f_speed.md "The training
step"). So the backward runs the kernel on the
gradient in channels-last and hands the result back in the input's layout. The kernel adds each input
pixel's contributions in the same order in either layout, so the gradient is the same, bit for bit
(``tests/models/test_training_paths.py``).
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn.functional as F
from torch import Tensor

from mcd.models import fast_paths
from mcd.models.cpu_fast.layout import memory_format


class BilinearUpsample(torch.autograd.Function):
    """``F.interpolate(x, size, mode="bilinear", align_corners=False)``, its gradient computed by ATen's
    kernel on the output's gradient in channels-last, returned in ``x``'s memory layout."""

    @staticmethod
    def forward(ctx, x: Tensor, size: tuple[int, int]) -> Tensor:  # noqa: ANN001
        ctx.shape = list(x.shape)
        ctx.layout = memory_format(x)
        return F.interpolate(x, size=size, mode="bilinear", align_corners=False)

    @staticmethod
    def backward(ctx, grad: Tensor) -> tuple[Tensor, None]:  # noqa: ANN001
        grad = grad.contiguous(memory_format=torch.channels_last)
        summed = torch.ops.aten.upsample_bilinear2d_backward(grad, list(grad.shape[-2:]), ctx.shape, False,
                                                             None, None)
        return summed.contiguous(memory_format=ctx.layout), None


def upsample_bilinear(x: Tensor, size: Sequence[int]) -> Tensor:
    """``F.interpolate(x, size=size, mode="bilinear", align_corners=False)`` of a 4-D ``x``; through
    :class:`BilinearUpsample` where a gradient of ``x`` is taken (fast path, :mod:`mcd.models.fast_paths`)."""
    size = (int(size[0]), int(size[1]))
    if fast_paths.enabled() and x.dim() == 4 and x.requires_grad and torch.is_grad_enabled():
        return BilinearUpsample.apply(x, size)
    return F.interpolate(x, size=size, mode="bilinear", align_corners=False)

"""Backward warping by motion vectors (NTASAD's output feedback, docs/baselines.md "NTASAD"; the
two-stage model's `method.warp_previous`, docs/method.md "Diagnostics").

The store's ``motion`` buffer (architecture.md) is backward motion in pixels: pixel ``(x, y)`` of frame
``t`` was at ``(x + mx, y + my)`` in frame ``t - 1``. Warping frame ``t - 1`` to frame ``t`` therefore
samples it there (bilinear, border clamp)."""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor


def warp(prev: Tensor, motion: Tensor) -> Tensor:
    """``prev`` ``[B, C, H, W]`` (frame t-1) resampled at ``p + motion`` for each pixel ``p`` of frame t."""
    if motion.shape[0] != prev.shape[0] or motion.shape[1] != 2 or motion.shape[-2:] != prev.shape[-2:]:
        raise ValueError(f"warp needs motion [B, 2, H, W] matching prev {tuple(prev.shape)}, got "
                         f"{tuple(motion.shape)}")
    b, _, h, w = prev.shape
    ys, xs = torch.meshgrid(torch.arange(h, device=prev.device, dtype=prev.dtype),
                            torch.arange(w, device=prev.device, dtype=prev.dtype), indexing="ij")
    x = xs + motion[:, 0].to(prev.dtype)
    y = ys + motion[:, 1].to(prev.dtype)
    # align_corners=False: pixel centre i sits at (2 i + 1) / size - 1.
    grid = torch.stack([(2 * x + 1) / w - 1, (2 * y + 1) / h - 1], -1)
    return F.grid_sample(prev, grid, mode="bilinear", padding_mode="border", align_corners=False)

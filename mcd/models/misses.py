"""Pixels that see no geometry keep the render's value (``method.pass_misses``; docs/method.md "Output").

Not in the paper. A pixel all of whose first hits miss the scene sees only the environment (black around the
Cornell boxes, the sky through a window), and a path tracer evaluates that without noise, so the render is
already as good as the reference there. A network blurs the frame's content into such pixels instead, which
costs PSNR along a black frame border (docs/method.md "Output" has the measurement). Every method that sets
the switch gets the render's value there instead, after its frame-mean match (:mod:`mcd.models.output_steps`).

The G-buffer marks the pixels: its normal is the box-filtered mean of the first hits' unit normals over
``data.gbuffer_spp`` samples (docs/data.md), exactly 0 in all three channels only where every sample missed.
A pixel partly covered by geometry that none of those samples hit is passed through as well, with the
render's noise (a few pixels along an edge).
"""

from __future__ import annotations

import torch
from torch import Tensor


def miss_mask(normal: Tensor) -> Tensor:
    """``[B, 1, H, W]``: True where the G-buffer normal ``[B, 3, H, W]`` is exactly 0 (no first hit)."""
    return (normal == 0).all(dim=1, keepdim=True)


def pass_misses(output: Tensor, render: Tensor, normal: Tensor) -> Tensor:
    """``output`` with the render's value where :func:`miss_mask` holds."""
    return torch.where(miss_mask(normal), render.to(output.dtype), output)


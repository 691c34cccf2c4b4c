"""Pixels that see no geometry keep the render's value (``method.pass_misses``; docs/method.md "Output").

Not in the paper. A pixel all of whose first hits miss the scene sees only the environment (black around the
Cornell boxes, the sky through room0's windows), and a path tracer evaluates that without noise: over such
pixels of the ``small`` test frames the 4 spp render differs from the reference by a median of 1.4e-6 on
room0 and 0 on cbox. The networks trained here blur the frame's content into them instead: on cbox's first
test frames, framed by a black margin of up to 4 rows and 2 columns (1 to 858 pixels per frame), row F's
output was about 0.05 (linear; the reference 0) along the frame border, an error of 0.25 after the metrics'
display transform (gamma 1/2.2), and those pixels alone cost F 1.0-4.6 dB of PSNR on a cbox frame
(docs/method.md "Output"). Every method that sets the switch gets the render's value there instead, after its
frame-mean match (:mod:`mcd.models.output_steps`).

The G-buffer marks the pixels: its normal is the box-filtered mean of the first hits' unit normals over
``data.gbuffer_spp`` samples (docs/data.md), exactly 0 in all three channels only where every sample missed.
A pixel partly covered by geometry that none of those samples hit is passed through as well, with the
render's noise (a few pixels along an edge: up to 0.27 from the reference on room0's window frames).
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


"""Pixels that see no geometry keep the render's value (``method.pass_misses``; docs/method.md "Output").

Not in the paper. A pixel all of whose first hits miss the scene sees only the environment (black around the
Cornell boxes, the sky through room0's windows), and a path tracer evaluates that without noise: over such
pixels of the ``small`` test frames the 4 spp render differs from the reference by a median of 1.4e-6 on
room0 and 0 on cbox. The networks trained here blur the frame's content into them instead: on cbox's first
test frames, framed by a black margin of up to 4 rows and 2 columns (1 to 858 pixels per frame), row F's
output was about 0.05 (linear; the reference 0) along the frame border, an error of 0.25 after the metrics'
display transform (gamma 1/2.2), and those pixels alone cost F 1.0-4.6 dB of PSNR on a cbox frame
(docs/method.md "Output"). Every method that sets the switch gets the render's value there instead, after its
other output steps.

The G-buffer marks the pixels: its normal is the box-filtered mean of the first hits' unit normals over
``data.gbuffer_spp`` samples (docs/data.md), exactly 0 in all three channels only where every sample missed.
A pixel partly covered by geometry that none of those samples hit is passed through as well, with the
render's noise (a few pixels along an edge: up to 0.27 from the reference on room0's window frames).
"""

from __future__ import annotations

from typing import Any

import torch
from torch import Tensor, nn

from mcd.models.mean_match import current_frame, denoised_render


def miss_mask(normal: Tensor) -> Tensor:
    """``[B, 1, H, W]``: True where the G-buffer normal ``[B, 3, H, W]`` is exactly 0 (no first hit)."""
    return (normal == 0).all(dim=1, keepdim=True)


def pass_misses(output: Tensor, render: Tensor, normal: Tensor) -> Tensor:
    """``output`` with the render's value where :func:`miss_mask` holds."""
    return torch.where(miss_mask(normal), render.to(output.dtype), output)


def attach_pass_misses(module: nn.Module, budget: float) -> nn.Module:
    """``module`` (a method's model: ``forward(x) -> {"output", ...}``, reading the ``normal`` G-buffer) with
    :func:`pass_misses` applied to its ``output`` by a forward hook (same parameters and state dict), with
    the render it denoised (:func:`mcd.models.mean_match.denoised_render`)."""
    past = int(getattr(module, "window", (0, 0))[0])

    def hook(_: nn.Module, args: tuple[Any, ...], out: dict[str, Tensor]) -> dict[str, Tensor]:
        x = args[0]
        normal = current_frame(x["normal"], past)
        out["output"] = pass_misses(out["output"], denoised_render(out, x, budget, past), normal)
        return out

    module.register_forward_hook(hook)
    return module

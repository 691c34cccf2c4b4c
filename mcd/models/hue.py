"""The output's hue taken from the kernel pool's ``i_bar`` (``method.denoiser_hue=i_bar``; not the paper's:
docs/method.md "Output").

``F_d``'s residual correction moves each colour channel on its own, and at the budgets trained here it moves
them apart: F's output is further from the reference in hue than its own input ``i_bar``, a filter of the
adaptive render, and than NTASAD's kernel-filtered output (notes/colour_error.md). With this step the output
keeps ``F_d``'s luminance (Rec. 709 ``Y``) and takes its chromaticity, ``rgb / Y``, from ``i_bar``
box-averaged over :data:`BOX` x :data:`BOX` pixels (the box steadies the hue where the pool left a raw
pixel). A pixel where either luminance is at most :data:`DARK` keeps ``F_d``'s colour: a black pixel has no
hue to give or take.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

#: Rec. 709 luminance weights of linear RGB.
Y_WEIGHTS = (0.2126, 0.7152, 0.0722)
#: Side of the square ``i_bar``'s chromaticity is averaged over.
BOX = 3
#: Luminance (linear) at or under which a pixel keeps ``F_d``'s own colour.
DARK = 1e-3


def luminance(image: Tensor) -> Tensor:
    """``[B, 1, H, W]`` luminance of linear ``[B, 3, H, W]`` RGB."""
    w = torch.tensor(Y_WEIGHTS, dtype=image.dtype, device=image.device).view(1, 3, 1, 1)
    return (image * w).sum(1, keepdim=True)


def box_mean(image: Tensor, box: int = BOX) -> Tensor:
    """``image`` averaged over ``box`` x ``box`` squares (reflected at the frame's edges; a side of 1 pixel
    is left as it is)."""
    pad = box // 2
    if pad == 0:
        return image
    mode = "reflect" if min(image.shape[-2:]) > pad else "replicate"
    return F.avg_pool2d(F.pad(image, (pad, pad, pad, pad), mode=mode), box, stride=1)


def hue_from(output: Tensor, guide: Tensor, box: int = BOX) -> Tensor:
    """``output``'s luminance with ``guide``'s box-averaged chromaticity where both are lit (luminance above
    :data:`DARK`), ``output`` elsewhere; both linear ``[B, 3, H, W]``. Gradients reach ``output`` through its
    luminance and ``guide`` through its chromaticity."""
    hue = box_mean(guide.float(), box)
    y_out, y_hue = luminance(output), luminance(hue)
    lit = (y_out > DARK) & (y_hue > DARK)
    scaled = y_out * hue / torch.where(lit, y_hue, torch.ones_like(y_hue))
    return torch.where(lit, scaled, output)

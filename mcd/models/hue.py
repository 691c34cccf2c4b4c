"""The output's hue taken from the kernel pool's ``i_bar`` (``method.denoiser_hue=i_bar`` or ``i_bar_grey``;
not the paper's: docs/method.md "Output").

``F_d``'s residual correction moves each colour channel on its own, and at the budgets trained here it moves
them apart: F's output is further from the reference in hue than its own input ``i_bar``, a filter of the
adaptive render, and than NTASAD's kernel-filtered output (notes/colour_error.md). With this step the output
keeps ``F_d``'s luminance (Rec. 709 ``Y``, :func:`mcd.models.inputs.grey`) and takes its chromaticity,
``rgb / Y``, from ``i_bar`` box-averaged over :data:`BOX` x :data:`BOX` pixels (the box steadies the hue where
the pool left a raw pixel). A pixel where either luminance is at most :data:`DARK` keeps ``F_d``'s colour: a
black pixel has no hue to give or take. With ``i_bar_grey`` ``F_d``'s correction is also made one value per
pixel (:func:`grey_correction`), so that ``F_d``'s own hue, which the loss no longer sees, cannot drift.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

from mcd.models.inputs import grey

#: Side of the square ``i_bar``'s chromaticity is averaged over.
BOX = 3
#: Luminance (linear) at or under which a pixel keeps ``F_d``'s own colour.
DARK = 1e-3


def box_mean(image: Tensor, box: int = BOX) -> Tensor:
    """``image`` averaged over ``box`` x ``box`` squares (reflected at the frame's edges; a side of 1 pixel
    is left as it is)."""
    pad = box // 2
    if pad == 0:
        return image
    mode = "reflect" if min(image.shape[-2:]) > pad else "replicate"
    return F.avg_pool2d(F.pad(image, (pad, pad, pad, pad), mode=mode), box, stride=1)


def grey_correction(correction: Tensor) -> Tensor:
    """``[B, 3, H, W]`` ``correction`` made one value per pixel, its channels' luminance-weighted mean, for
    the three channels (``method.denoiser_hue=i_bar_grey``): a residual ``F_d`` then moves a pixel's
    brightness and not its hue, and its own hue cannot drift where :func:`hue_from` leaves the output's
    chromaticity free of the loss (docs/method.md "Output")."""
    return grey(correction).expand_as(correction)


def hue_from(output: Tensor, guide: Tensor, box: int = BOX) -> Tensor:
    """``output``'s luminance with ``guide``'s box-averaged chromaticity where both are lit (luminance above
    :data:`DARK`), ``output`` elsewhere; both linear ``[B, 3, H, W]``. Gradients reach ``output`` through its
    luminance and ``guide`` through its chromaticity."""
    hue = box_mean(guide.float(), box)
    y_out, y_hue = grey(output), grey(hue)
    lit = (y_out > DARK) & (y_hue > DARK)
    scaled = y_out * hue / torch.where(lit, y_hue, torch.ones_like(y_hue))
    return torch.where(lit, scaled, output)

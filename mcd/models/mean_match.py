"""Frame-mean matching of the output (``method.mean_match``; docs/method.md, "Output").

Not in the paper. A Monte Carlo render is an unbiased estimate of the reference, so the mean of a whole frame
of it, per colour channel, estimates the reference's frame mean closely (at 4 spp on the ``small`` profile
within 0.5-3% per scene), while a denoiser trained in a compressed colour range can lose or shift that
energy, most on scenes it was not trained on (docs/method.md, "Output", gives the measurements).
:func:`match_frame_mean` rescales each channel of the output so that its mean equals the render's over the
pixels that are not highlights. Highlights (an output channel above :data:`HIGHLIGHT`, 8x the frame average
the store's exposure sets) are left out of both means: a visible light source can hold most of a frame's
linear energy while the loss, in the compressed range, barely constrains its value, and an error there would
rescale the whole image (measured: docs/method.md). The mask comes from the output, which has little noise,
so the render's mean over it stays an unbiased estimate of the reference's. The gain is part of the model in
training too (gradients flow through it), so the network learns the image up to a per-channel scale and the
scale comes from the render.
"""

from __future__ import annotations

import torch
from torch import Tensor

#: Added to both means so that an all-black frame (or channel) keeps a gain of 1 and no division by zero.
EPS = 1e-6
#: The gain is clamped to ``[1 / GAIN_MAX, GAIN_MAX]``: an output channel that is (nearly) black everywhere,
#: as at initialisation, would otherwise get a gain of up to ``mean / EPS`` and its gradients with it.
GAIN_MAX = 8.0
#: A pixel whose output exceeds this in any channel is a highlight, left out of both means. The store's
#: exposure sets a frame's mean reference value to 0.5 (``data.exposure_target``; docs/data.md), so this is
#: 8x a frame's average.
HIGHLIGHT = 4.0


def match_frame_mean(output: Tensor, render: Tensor) -> Tensor:
    """``output * gain`` per image and channel (``[B, 3, H, W]``, linear HDR, computed in fp32), ``gain =
    (mean(render) + EPS) / (mean(output) + EPS)`` over the pixels where no output channel exceeds
    ``HIGHLIGHT``, clamped to ``[1 / GAIN_MAX, GAIN_MAX]``; 1 where every pixel is a highlight. The means are
    taken of values clamped at 0 (``mcd.models.inputs.expand`` produces none below 0; a render has none after
    the store's sanitising)."""
    out = output.float()
    keep = (out.detach().amax(dim=1, keepdim=True) <= HIGHLIGHT).float()
    count = keep.sum(dim=(-2, -1), keepdim=True)
    want = (render.float().clamp_min(0) * keep).sum(dim=(-2, -1), keepdim=True)
    have = (out.clamp_min(0) * keep).sum(dim=(-2, -1), keepdim=True)
    gain = ((want + EPS * count) / (have + EPS * count)).clamp(1.0 / GAIN_MAX, GAIN_MAX)
    return out * torch.where(count > 0, gain, torch.ones_like(gain))

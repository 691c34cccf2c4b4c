"""Frame-mean matching of the output (``method.mean_match``; docs/method.md, "Output").

Not in the paper. A Monte Carlo render is an unbiased estimate of the reference, so the mean of a whole frame
of it, per colour channel, estimates the reference's frame mean closely (at 4 spp on the ``small`` profile
within 0.5-3% per scene), while a denoiser trained in a compressed colour range can lose or shift that
energy, most on scenes it was not trained on (docs/method.md, "Output", gives the measurements).
:func:`match_frame_mean` rescales each channel of the output so that its frame mean equals the input's.
The gain is part of the model in training too (gradients flow through it), so the network learns the
image up to a per-channel scale and the scale comes from the render.
"""

from __future__ import annotations

from torch import Tensor

#: Added to both means so that an all-black frame (or channel) keeps a gain of 1 and no division by zero.
EPS = 1e-6
#: The gain is clamped to ``[1 / GAIN_MAX, GAIN_MAX]``: an output channel that is (nearly) black everywhere,
#: as at initialisation, would otherwise get a gain of up to ``mean / EPS`` and its gradients with it.
GAIN_MAX = 8.0


def match_frame_mean(output: Tensor, render: Tensor) -> Tensor:
    """``output * (mean(render) + EPS) / (mean(output) + EPS)`` per image and channel (``[B, 3, H, W]``,
    linear HDR, computed in fp32), the gain clamped to ``[1 / GAIN_MAX, GAIN_MAX]``. The means are taken of
    values clamped at 0 (``mcd.models.inputs.expand`` produces none below 0; a render has none after the
    store's sanitising)."""
    out = output.float()
    want = render.float().clamp_min(0).mean(dim=(-2, -1), keepdim=True)
    have = out.clamp_min(0).mean(dim=(-2, -1), keepdim=True)
    return out * ((want + EPS) / (have + EPS)).clamp(1.0 / GAIN_MAX, GAIN_MAX)

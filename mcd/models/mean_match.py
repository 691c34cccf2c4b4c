"""Frame-mean matching of the output (``method.mean_match``; docs/method.md, "Output").

Not in the paper. A Monte Carlo render is an unbiased estimate of the reference, so the mean of a whole frame
of it, per colour channel, estimates the reference's frame mean closely (at 4 spp on the ``small`` profile
within 0.5-3% per scene), while a denoiser trained in a compressed colour range can lose or shift that
energy, most on scenes it was not trained on (docs/method.md, "Output", gives the measurements).
:func:`match_frame_mean` rescales each channel of the output so that its mean equals the render's, separately
for the highlights (the output brighter than about :data:`HIGHLIGHT`, 8x a frame's average) and for the rest,
with a smooth weight between the two bands. One gain for the whole frame let a visible light source, which
holds most of a frame's linear energy while the loss (in the compressed range) barely constrains its value,
rescale every other pixel when the network got the light wrong; a gain without the highlights left the lights
and bright regions uncorrected (both measured: docs/method.md). The band weights come from the output, which
has little noise, so the render's means over them stay unbiased estimates of the reference's; the output is
first brought to the render's scale by the ratio of the two frames' medians, so that its own scale moves no
pixel between the bands.

``method.mean_match`` says when the step runs (:mod:`mcd.models.output_steps`): ``test`` (the default) in
validation and test only, so that the training loss sees the network's own output and fixes its scale;
``true`` in training too, with gradients through the gains, which leave the network's scale free: a trained
F's raw output drifted 1.4-3x too bright, and its brightness along the frame's edges drifted apart from the
interior's, which one gain per band cannot undo (on ``tiny``'s cbox a ring too bright by 0.03 in display
values, which put its FLIP above the noisy input's; docs/method.md "Output").

Every method that sets ``method.mean_match`` gets it, matched to the render it denoised
(:mod:`mcd.models.output_steps`), so every learned method of Table 1 ends in the same output step
(docs/baselines.md, "Output").
"""

from __future__ import annotations

import math

import torch
from torch import Tensor

from mcd.data.exposure import OUTLIER_FACTOR, OUTLIER_QUANTILE

#: Added to both means so that an all-black frame (or channel) keeps a gain of 1 and no division by zero.
EPS = 1e-6
#: The gain is clamped to ``[1 / GAIN_MAX, GAIN_MAX]``: an output channel that is (nearly) black everywhere,
#: as at initialisation, would otherwise get a gain of up to ``mean / EPS`` and its gradients with it.
GAIN_MAX = 8.0
#: The centre of the highlight band: a pixel whose largest output channel is this bright belongs half to the
#: highlights. The store's exposure sets a frame's mean reference value to 0.5 (``data.exposure_target``;
#: docs/data.md), so this is 8x a frame's average.
HIGHLIGHT = 4.0


def _band_gain(out: Tensor, render: Tensor, weight: Tensor) -> Tensor:
    """Per image and channel, ``(sum(w * render) + e) / (sum(w * out) + e)``, ``e = EPS * sum(w) + 1e-12``,
    clamped to ``[1 / GAIN_MAX, GAIN_MAX]``; 1 where the band is empty (no ``where``: its other branch's NaN
    would reach the gradients)."""
    e = EPS * weight.sum(dim=(-2, -1), keepdim=True) + 1e-12
    want = (render * weight).sum(dim=(-2, -1), keepdim=True)
    have = (out * weight).sum(dim=(-2, -1), keepdim=True)
    return ((want + e) / (have + e)).clamp(1.0 / GAIN_MAX, GAIN_MAX)


def _median_ratio(render: Tensor, seen: Tensor) -> Tensor:
    """``[B, 1, 1, 1]``: the frame median of the render's largest channel over that of ``seen`` (the output's
    largest channel), clamped to ``[1 / GAIN_MAX, GAIN_MAX]``: the output's scale against the render's where
    most pixels are, which no light and no highlight moves."""
    b = render.shape[0]
    want = render.detach().amax(dim=1).reshape(b, -1).median(dim=1).values
    have = seen.reshape(b, -1).median(dim=1).values
    return ((want + EPS) / (have + EPS)).clamp(1.0 / GAIN_MAX, GAIN_MAX).view(b, 1, 1, 1)


def without_fireflies(render: Tensor) -> Tensor:
    """``render`` ``[B, C, H, W]`` with each image's values clamped at :data:`OUTLIER_FACTOR` times the
    :data:`OUTLIER_QUANTILE` of its positive values, the rule the input's exposure is measured by
    (:func:`mcd.data.exposure.measure_exposure`): a firefly is clamped, a light covering more than the
    quantile's share of the frame sets the quantile and is kept. The band means are taken of this: one pixel
    of 1e5 in a 32 x 32 frame put its energy into the highlight band's gain, and every highlight of the frame
    came out 20-55% brighter (docs/method.md, "Output")."""
    if render.is_meta:  # MACs counted: no values
        return render
    bounds = []
    for img in render.detach():
        positive = img[img > 0]
        if positive.numel() == 0:
            bounds.append(math.inf)
            continue
        k = max(1, math.ceil(OUTLIER_QUANTILE * positive.numel()))
        bounds.append(OUTLIER_FACTOR * float(positive.kthvalue(k).values))
    bound = torch.tensor(bounds, dtype=render.dtype, device=render.device)
    return torch.minimum(render, bound.view(-1, 1, 1, 1))


#: How far (pixels) a network spreads a firefly it reads: the output within it is left out of the band
#: means (:func:`firefly_reach`).
FIREFLY_REACH = 8


def firefly_reach(render: Tensor, clamped: Tensor) -> Tensor:
    """``[B, 1, H, W]``: 1 within :data:`FIREFLY_REACH` pixels of a value :func:`without_fireflies` clamped,
    else 0. The output there holds the network's response to the firefly, which the clamped render no longer
    asks of it: counted, it pulled the highlight band's gain down, and far highlights 20-34% darker."""
    hit = (render > clamped).any(dim=1, keepdim=True).float()
    if render.is_meta or not bool(hit.any()):
        return hit
    side = 2 * FIREFLY_REACH + 1
    return torch.nn.functional.max_pool2d(hit, side, stride=1, padding=FIREFLY_REACH)


def match_frame_mean(output: Tensor, render: Tensor) -> Tensor:
    """``output`` with each channel's mean matched to the render's, separately over the highlights and over
    the rest (``[B, 3, H, W]``, linear HDR, computed in fp32; module docstring). A pixel's highlight weight
    rises smoothly from 0 at ``HIGHLIGHT / 4`` to 1 at ``HIGHLIGHT * 4`` (in log brightness of the output's
    largest channel times :func:`_median_ratio`, without gradient; so scaling ``output`` by ``k`` changes no
    weight and the result not at all while the medians' ratio stays within its clamp), and its gain is the
    weighted mix of the two bands' gains, so the frame mean is matched as a whole too. The render's fireflies
    are clamped first (:func:`without_fireflies`). Values are clamped at 0 first (``mcd.models.inputs.expand``
    produces none below 0; a render has none after the store's sanitising)."""
    out = output.float().clamp_min(0)
    plain = render.float().clamp_min(0)
    rend = without_fireflies(plain)
    seen = out.detach().amax(dim=1, keepdim=True)
    level = torch.log2((seen * _median_ratio(rend, seen)).clamp_min(1e-12) / HIGHLIGHT)
    w = ((level + 2.0) / 4.0).clamp(0.0, 1.0)
    w = w * w * (3.0 - 2.0 * w)  # smoothstep
    away = 1.0 - firefly_reach(plain, rend)  # the band means are taken away from the fireflies
    gain = w * _band_gain(out, rend, w * away) + (1.0 - w) * _band_gain(out, rend, (1.0 - w) * away)
    return output.float() * gain


"""The reflected margin every convolutional method's denoiser reads outside training
(``method.denoiser_margin``; docs/method.md "Frame edges", docs/baselines.md "Frame edges"; not in the paper).

A convolutional denoiser's edge pixels see its zero padding, and a training crop's edges are rarely the
frame's, so little of the training teaches them. Outside training, the denoiser reads its input reflected by
the margin on every side (at most ``H - 1`` and ``W - 1``: a small frame is reflected as far as it goes) and
its output is cropped back; in training it reads the crop as it is. The same for every method with a
denoiser of its own: the U-Net (row A) and rows B-M (``F_d``), RAE, FastDVDnet, DASR and NTASAD. Each calls
:func:`with_margin` at its denoiser; :func:`set_margin` (called by :func:`mcd.models.registry.build`) is the
one place that reads the key, 0 for a method whose file does not set it (the noisy input, OIDN). Only the
denoiser: a sampler and the adaptive render read the frame itself, so that the budget is spent on the frame's
pixels, and a recurrent method's fed-back state (NTASAD's warped previous output) stays at the frame's size.
"""

from __future__ import annotations

from collections.abc import Callable

import torch.nn.functional as F
from omegaconf import DictConfig
from torch import Tensor, nn

#: ``method.denoiser_margin``'s key, as errors name it
KEY = "method.denoiser_margin"


def set_margin(module: nn.Module, method: DictConfig) -> nn.Module:
    """``module`` with ``denoiser_margin`` set from ``method`` (0 where the key is absent). ValueError naming
    the key for a negative margin, or a margin on a method without a denoiser of its own (its class does not
    declare ``denoiser_margin``)."""
    margin = method.get("denoiser_margin", 0)
    if margin is None or isinstance(margin, bool) or not isinstance(margin, int) or margin < 0:
        raise ValueError(f"{KEY}={margin}: give 0 (off) or a number of pixels")
    if not hasattr(type(module), "denoiser_margin"):
        if margin:
            raise ValueError(f"{KEY}={margin}: method {method.get('name')} has no denoiser of this project's "
                             "to reflect its input for; remove the key or set it to 0")
        return module
    module.denoiser_margin = int(margin)
    return module


def reflect(t: Tensor, margin: int) -> Tensor:
    """``t`` ``[..., H, W]`` (4 or 5 dimensions: a window of frames) reflected by ``margin`` pixels on every
    side."""
    if t.dim() == 5:
        return reflect(t.flatten(0, 1), margin).unflatten(0, t.shape[:2])
    return F.pad(t, (margin, margin, margin, margin), mode="reflect")


def with_margin(module: nn.Module, denoise: Callable[..., Tensor], *images: Tensor) -> Tensor:
    """``denoise(*images)``; outside training (``module.training`` false) on `images` each reflected by
    ``module.denoiser_margin`` pixels (at most ``H - 1`` and ``W - 1`` of the first image), the output
    ``[..., H', W']`` cropped back to ``H x W``. `denoise` takes frames of any size."""
    h, w = images[0].shape[-2:]
    margin = 0 if module.training else min(int(module.denoiser_margin), h - 1, w - 1)
    if margin == 0:
        return denoise(*images)
    y = denoise(*(reflect(t, margin) for t in images))
    return y[..., margin:-margin, margin:-margin]

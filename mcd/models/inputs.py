"""Input preparation shared by the two-stage networks (docs/method.md "Inputs").

Colour enters the networks compressed (default ``log1p``, ``method.colour``) and leaves through the inverse;
depth enters as ``log1p(depth)`` so distant surfaces stay in range; the sampler also sees two grey images.
Networks that halve the resolution pad their input (replicate) to a multiple of their stride and crop back.
"""

from __future__ import annotations

import functools
from collections.abc import Sequence

import torch
import torch.nn.functional as F
from torch import Tensor

#: Rec. 709 luminance weights, for the grey images the sampling network sees.
LUMA = (0.2126, 0.7152, 0.0722)
#: Largest compressed value fed back through the inverse transform (log1p range: expm1(20) ~ 4.9e8).
MAX_COMPRESSED = 20.0
COLOUR_TRANSFORMS = ("log1p", "none")


def need(x: dict[str, Tensor | None], name: str, who: str) -> Tensor:
    """``x[name]``, or a ``KeyError`` that names the buffer and the model that reads it."""
    value = x.get(name)
    if value is None:
        present = sorted(k for k, v in x.items() if isinstance(v, Tensor))
        raise KeyError(f"{who} needs buffer {name!r} in its input (its required_buffers() lists it); "
                       f"got {present}")
    return value


def compress(c: Tensor, transform: str = "log1p") -> Tensor:
    """Linear HDR colour -> network range (negative values clamped to 0 first)."""
    if transform == "log1p":
        return torch.log1p(c.clamp_min(0))
    if transform == "none":
        return c.clamp_min(0)
    raise ValueError(f"unknown colour transform {transform!r}; use one of {COLOUR_TRANSFORMS}")


def expand(y: Tensor, transform: str = "log1p") -> Tensor:
    """Network range -> linear HDR colour, in fp32, never negative, never Inf/NaN for finite ``y``.

    The clamp to ``[0, MAX_COMPRESSED]`` passes gradients straight through, so an output pushed below zero
    (e.g. at initialisation) still learns instead of sitting in the clamp's flat region.
    """
    y = y.float()
    y = y + (y.clamp(0, MAX_COMPRESSED) - y).detach()
    if transform == "log1p":
        return torch.expm1(y)
    if transform == "none":
        return y
    raise ValueError(f"unknown colour transform {transform!r}; use one of {COLOUR_TRANSFORMS}")


def grey(c: Tensor) -> Tensor:
    """Luminance ``[B, 1, H, W]`` of an RGB image ``[B, 3, H, W]``."""
    w = c.new_tensor(LUMA).view(1, 3, 1, 1)
    return (c * w).sum(1, keepdim=True)


def gbuffers(x: dict[str, Tensor | None], who: str) -> Tensor:
    """The 7 G-buffer channels ``[log1p(depth), normal, albedo]`` of one frame, ``[B, 7, H, W]``
    (channels-last where the normals are: :func:`cat_channels`)."""
    depth = need(x, "depth", who)
    return cat_channels([torch.log1p(depth.clamp_min(0)), need(x, "normal", who), need(x, "albedo", who)])


def pad_to_multiple(t: Tensor, multiple: int) -> Tensor:
    """Replicate-pad the bottom/right of ``[B, C, H, W]`` so that H and W are multiples of ``multiple``."""
    h, w = t.shape[-2:]
    ph, pw = (-h) % multiple, (-w) % multiple
    if ph == 0 and pw == 0:
        return t
    return F.pad(t, (0, pw, 0, ph), mode="replicate")


def crop(t: Tensor, size: tuple[int, int]) -> Tensor:
    """Top-left ``size`` crop, the inverse of :func:`pad_to_multiple`."""
    return t[..., : size[0], : size[1]]


def cat_channels(tensors: Sequence[Tensor]) -> Tensor:
    """``torch.cat(tensors, 1)``, channels-last when an input of several channels is and no gradient is
    recorded.

    ``torch.cat`` keeps channels-last only when every input suggests it, and a one-channel tensor (depth, a
    grey image) suggests the contiguous format, so every convolution that read the concatenation would first
    reorder it (docs/inference.md, "Channels-last concatenations"). ``torch.cat(out=...)`` has no gradient,
    so with gradients recorded this is ``torch.cat`` itself."""
    cl = torch.channels_last
    if torch.is_grad_enabled() or not any(t.dim() == 4 and t.shape[1] > 1
                                          and t.is_contiguous(memory_format=cl) for t in tensors):
        return torch.cat(list(tensors), 1)
    dtype = functools.reduce(torch.promote_types, [t.dtype for t in tensors])
    b, _, h, w = tensors[0].shape
    out = torch.empty(b, sum(t.shape[1] for t in tensors), h, w, dtype=dtype, device=tensors[0].device,
                      memory_format=cl)
    return torch.cat(list(tensors), 1, out=out)


def broadcast(constant: Tensor, like: Tensor) -> Tensor:
    """``constant`` ``[B, D]`` as ``D`` channels over ``like``'s image, in its dtype."""
    b, _, h, w = like.shape
    return constant[:, :, None, None].expand(b, constant.shape[1], h, w).to(like.dtype)


def with_constant(parts: Sequence[Tensor], constant: Tensor | None) -> list[Tensor]:
    """``parts``, followed by ``constant`` ``[B, D]`` broadcast over the first part's image when given: the
    channel parts of a block's input whose concatenation the block reads."""
    return [*parts, *([] if constant is None else [broadcast(constant, parts[0])])]

"""The output bound (``method.output_bound``; docs/method.md "Output", docs/reliability.md "Hard scenes").

Not in the paper. A network can blow up on a frame unlike its training data: on a dark interior with a few
fireflies (kitchenette at 4 spp), the bundled U-Net put a few pixels orders of magnitude above anything in its
input, and its rMSE went from the input's 169 to about 2.9e6. A denoiser redistributes the energy of its
input over a neighbourhood; it has no reason to put a pixel far above the brightest local average of that
input. :func:`output_bound` is that ceiling, per pixel, in the linear HDR domain of the render the method
denoised (:func:`mcd.models.output_steps.denoised_render`), read off its brightest channel ``m``:

``bound = REACH_GAIN x max over a REACH x REACH neighbourhood of (the second-largest m of each 3 x 3 window)
+ the frame's FLOOR_QUANTILE quantile of m``.

- The second-largest value of a 3 x 3 window is a local maximum that a lone pixel cannot set: a firefly is
  one bright pixel among dark ones, so around it the level is its neighbours', while a light or a highlight
  of two pixels or more keeps its own value. A neighbourhood mean does not tell the two apart: over a 7 x 7
  window it held a Cornell box's light at 32 x 32 (a few pixels) below its own value, and the bundled
  networks' correct outputs there were clamped.
- The max of those values over a ``REACH`` window lets an output edge sit a few pixels off the input's (a
  blurred or shifted highlight), and ``REACH_GAIN`` leaves room above the noisy level.
- The floor, the frame's robust high value (a quantile, so a few fireflies do not move it), keeps the bound
  above 0 where the render is black (zero-sample pixels, an unlit region the network lights from context).

:func:`clamp_output` clamps every channel to ``[0, bound]`` (radiance is not negative) and replaces a
non-finite value by the render's 3 x 3 mean. It runs outside training only (``mcd.models.output_steps``): a
clamp in training would zero the gradients of the pixels it holds, and the loss should teach the network
those pixels instead. The measured effect on ordinary frames and on hard ones is in docs/method.md "Output".

Fast path (:mod:`mcd.models.fast_paths`, docs/inference.md "Fast paths"): the same values by cheaper
operations, each exact (maxima, minima and order statistics round nothing): the second-largest value of each
3 x 3 window by a top-two merge over shifted views instead of ``unfold`` and ``topk``
(:func:`second_largest_3x3`), the ``REACH`` x ``REACH`` maximum as two separable passes of shifted maxima
(:func:`window_max`), the quantile from two ``kthvalue`` selections instead of a full sort (:func:`quantile`),
and the render's 3 x 3 mean only when the output holds a non-finite value. Checked bit for bit against the
reference in ``tests/models/test_fast_paths.py``.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

from mcd.models import fast_paths

#: Side of the neighbourhood over which the robust local maxima are taken (pixels, odd).
REACH = 7
#: How far above the neighbourhood's robust maximum an output may go.
REACH_GAIN = 2.0
#: The quantile of the frame's brightest channel added to every pixel's bound (the frame's robust high).
FLOOR_QUANTILE = 0.99
#: Pixels of a frame sampled for its quantile beyond this count (``torch.quantile`` takes at most 2^24).
QUANTILE_SAMPLES = 1 << 22


def _finite(render: Tensor) -> Tensor:
    """``render`` in fp32 without gradient, NaN/Inf and negatives as 0."""
    r = render.detach().float()
    return torch.nan_to_num(r, nan=0.0, posinf=0.0, neginf=0.0).clamp_min(0.0)


def _floor(m: Tensor) -> Tensor:
    """``[B, 1, 1, 1]``: each frame's :data:`FLOOR_QUANTILE` quantile of ``m`` (a strided subsample when a
    frame has more than :data:`QUANTILE_SAMPLES` pixels)."""
    flat = m.flatten(1)
    step = max(1, -(-flat.shape[1] // QUANTILE_SAMPLES))
    if fast_paths.enabled():
        return quantile(flat[:, ::step], FLOOR_QUANTILE).view(-1, 1, 1, 1)
    return torch.quantile(flat[:, ::step], FLOOR_QUANTILE, dim=1).view(-1, 1, 1, 1)


def quantile(x: Tensor, q: float) -> Tensor:
    """``torch.quantile(x, q, dim=1)`` (linear interpolation) of a NaN-free ``x`` ``[B, N]``, from the two
    order statistics it interpolates (``kthvalue``, a selection in linear time) instead of a sort of ``N``
    values, with the same rank and weight arithmetic (``q`` in ``x``'s dtype times ``N - 1``), so the same
    value."""
    n = x.shape[1]
    rank = torch.tensor(q, dtype=x.dtype) * (n - 1)
    below, above = int(rank), int(torch.ceil(rank))
    low = torch.kthvalue(x, below + 1, dim=1).values
    high = low if above == below else torch.kthvalue(x, above + 1, dim=1).values
    return torch.lerp(low, high, (rank - below).to(x.device))


def robust_local_max(m: Tensor) -> Tensor:
    """``[B, 1, H, W]``: the second-largest value of ``m`` ``[B, 1, H, W]`` in each pixel's 3 x 3 window
    (zeros beyond the frame's edges)."""
    if fast_paths.enabled():
        return second_largest_3x3(m)
    b, _, h, w = m.shape
    return F.unfold(m, 3, padding=1).topk(2, dim=1).values[:, 1].view(b, 1, h, w)


def _top_two(values: list[Tensor]) -> tuple[Tensor, Tensor]:
    """Element-wise largest and second-largest (a repeated largest counts twice, as ``topk``) of
    ``values``."""
    first, second = torch.maximum(values[0], values[1]), torch.minimum(values[0], values[1])
    for v in values[2:]:
        second = torch.maximum(second, torch.minimum(first, v))
        first = torch.maximum(first, v)
    return first, second


def second_largest_3x3(m: Tensor) -> Tensor:
    """:func:`robust_local_max` of a NaN-free ``m``: the top two of each row of 3 (shifted views of ``m``
    zero-padded by one pixel), then of each column of 3 of those pairs (the top two of a union are the top
    two of its parts' top twos)."""
    h, w = m.shape[-2:]
    p = F.pad(m, (1, 1, 1, 1))
    first, second = _top_two([p[..., :, j : j + w] for j in range(3)])                # [B, 1, H + 2, W]
    rows = [(first[..., i : i + h, :], second[..., i : i + h, :]) for i in range(3)]
    top, runner = rows[0]
    for a, b in rows[1:]:
        runner = torch.maximum(torch.minimum(top, a), torch.maximum(runner, b))
        top = torch.maximum(top, a)
    return runner


def window_max(m: Tensor, size: int) -> Tensor:
    """``F.max_pool2d(m, size, stride=1, padding=size // 2)`` (odd ``size``; ``-inf`` beyond the edges) of a
    NaN-free ``m``, as a pass along the rows and one along the columns, each by doubling: the maximum over 2,
    4, ... neighbours from two shifted maxima of half the span, the last span overlapping."""
    r = size // 2

    def along(x: Tensor, dim: int) -> Tensor:
        n = x.shape[dim] - 2 * r
        span = 1
        while span < size:
            step = min(span, size - span)
            x = torch.maximum(x.narrow(dim, 0, x.shape[dim] - step), x.narrow(dim, step, x.shape[dim] - step))
            span += step
        return x.narrow(dim, 0, n)

    x = F.pad(m, (r, r, r, r), value=float("-inf"))
    return along(along(x, -1), -2)


def output_bound(render: Tensor) -> Tensor:
    """``[B, 1, H, W]``: the largest value an output pixel may take for the render ``[B, C, H, W]`` it
    denoised (module docstring)."""
    m = _finite(render).amax(dim=1, keepdim=True)
    local = robust_local_max(m)
    if fast_paths.enabled():
        reach = window_max(local, REACH)
    else:
        reach = F.max_pool2d(local, REACH, stride=1, padding=REACH // 2)
    return REACH_GAIN * reach + _floor(m)


def clamp_output(output: Tensor, render: Tensor) -> Tensor:
    """``output`` ``[B, 3, H, W]`` with every channel within ``[0, output_bound(render)]`` and a non-finite
    value replaced by the render's 3 x 3 mean (in ``output``'s dtype)."""
    bound = output_bound(render)
    out = output.float()
    finite = torch.isfinite(out)
    if out.is_meta or not (fast_paths.enabled() and bool(finite.all())):   # meta: MACs counted
        mean = F.avg_pool2d(_finite(render), 3, stride=1, padding=1, count_include_pad=False)
        out = torch.where(finite, out, mean)
    return torch.minimum(out.clamp_min(0.0), bound).to(output.dtype)

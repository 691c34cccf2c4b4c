"""Sampling-map normalisation (docs/method.md "Adaptive sampling" step 1; paper Eq. 1).

``m = round(softmax(m̄) * N * (s - 1))`` per frame, each pixel capped at ``2^0 + ... + 2^t`` (63 for ``t =
5``), with an exact budget: ``sum(m) == N * (s - 1)`` for every frame. The cap is honoured by water-filling
(the capped pixels' excess goes to the others in proportion to their share) and the rounding by largest
remainder (ties to the lower pixel index). Everything here is a non-differentiable integer map; the gradient
is :mod:`mcd.sampling.dasr_grad`'s job.

Neither step sorts the ``N`` pixels (a sort of a 1080p frame's pixels is a large share of the frame's time;
docs/inference.md): water-filling grows the capped set until it is stable (a few passes), and the
largest remainders are those above the ``k``-th largest (``kthvalue``, linear time).
"""

from __future__ import annotations

import torch
from torch import Tensor

#: Mixed into the softmax so that every pixel keeps a positive share: with logits of +-1e4 the softmax is
#: one-hot and water-filling alone could not place the samples the cap refuses (changes m by < 1e-6 spp).
UNIFORM_MIX = 1e-6


def cap_for_levels(levels: int) -> int:
    """Most samples one pixel can get from the stack ``c_1, c_2, ..., c_{2^levels}``: ``2^(levels+1) - 1``."""
    return 2 ** (levels + 1) - 1


def frame_budget(n_pixels: int, budget: float) -> int:
    """Adaptive samples per frame, ``N * (s - 1)`` (``c_1`` already spent one per pixel)."""
    return int(round(n_pixels * (budget - 1)))


def check_logits(logits: Tensor) -> None:
    """Raise a ``ValueError`` naming the problem when sampling logits hold NaN or Inf."""
    bad = ~torch.isfinite(logits)
    if bool(bad.any()):
        raise ValueError(f"sampling logits hold {int(bad.sum())} NaN/Inf values of {logits.numel()}; "
                         "the sampling network diverged or its input holds NaN/Inf (check the c1_in buffer)")


def shares(logits: Tensor) -> Tensor:
    """Per-frame softmax over all pixels of ``[B, 1, H, W]`` logits, in fp32 (safe under autocast)."""
    check_logits(logits)
    b = logits.shape[0]
    return torch.softmax(logits.float().reshape(b, -1), dim=1).reshape(logits.shape)


@torch.no_grad()
def normalise_map(p: Tensor, budget: float, cap: int = 63) -> Tensor:
    """Integer sampling map ``m`` (float tensor, ``[B, 1, H, W]``) from per-frame shares ``p`` (each frame
    sums to 1).

    ``sum(m[b]) == N * (s - 1)`` exactly and ``0 <= m <= cap``. Raises ``ValueError`` for NaN shares or a
    budget the cap cannot hold (``s - 1 > cap``).
    """
    if not bool(torch.isfinite(p).all()):
        raise ValueError("sampling shares hold NaN/Inf; the sampling network's logits are not finite")
    b = p.shape[0]
    flat = p.detach().reshape(b, -1).double().clamp_min(0)
    n = flat.shape[1]
    total = frame_budget(n, budget)
    if total < 0:
        raise ValueError(f"budget s={budget} is below 1 spp; the adaptive renderer needs s >= 1")
    if total > cap * n:
        raise ValueError(f"budget s={budget} needs {budget - 1} adaptive spp per pixel, more than the cap "
                         f"{cap} (raise method.sampling.levels or lower the budget)")
    flat = flat / flat.sum(1, keepdim=True).clamp_min(1e-300)
    flat = (1 - UNIFORM_MIX) * flat + UNIFORM_MIX / n
    raw = _water_fill(flat, float(total), float(cap))
    floor = raw.floor()
    deficit = (total - floor.sum(1)).round().long()                          # [B], in [0, N)
    remainder = torch.where(floor >= cap, torch.full_like(raw, -1.0), raw - floor)
    m = floor + _largest(remainder, deficit).double()
    if not (bool((m.sum(1) == total).all()) and float(m.max()) <= cap and float(m.min()) >= 0):
        raise RuntimeError(f"sampling-map normalisation broke its invariant: sums {m.sum(1).tolist()} != "
                           f"{total} or values outside [0, {cap}]")
    return m.to(p.dtype if p.dtype.is_floating_point else torch.float32).reshape(p.shape)


def _water_fill(p: Tensor, total: float, cap: float) -> Tensor:
    """``min(lam * p, cap)`` with, per row, the ``lam`` that makes the row sum to ``total`` (rows of ``p > 0``
    that sum to 1).

    The capped set ``C`` starts empty; ``lam = (total - |C| cap) / (sum of p outside C)`` and ``C`` gains
    every pixel with ``lam * p > cap``, until no pixel joins. ``lam`` only grows, so the set only grows and
    the fixed point is the unique water level.
    """
    capped = torch.zeros_like(p, dtype=torch.bool)
    lam = torch.full_like(p[:, :1], total)
    n_capped = -1
    while True:
        capped |= lam * p > cap
        now = int(capped.sum())
        if now == n_capped:
            return torch.where(capped, torch.full_like(p, cap), lam * p)
        n_capped = now
        free = p.masked_fill(capped, 0).sum(1, keepdim=True)
        lam = (total - cap * capped.sum(1, keepdim=True)) / free.clamp_min(1e-300)


def _largest(values: Tensor, counts: Tensor) -> Tensor:
    """Mask of the ``counts[b]`` largest entries of each row of ``values`` (ties to the lower index)."""
    chosen = torch.zeros_like(values, dtype=torch.bool)
    n = values.shape[1]
    for i, (row, k) in enumerate(zip(values, counts.tolist(), strict=True)):
        if k <= 0:
            continue
        threshold = row.kthvalue(n - k + 1).values
        above, tie = row > threshold, row == threshold
        need = k - int(above.sum())
        chosen[i] = above | (tie & (tie.cumsum(0) <= need))
    return chosen

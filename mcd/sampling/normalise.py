"""Sampling-map normalisation (docs/method.md "Adaptive sampling" step 1; paper Eq. 1).

``m = round(softmax(m̄) * N * (s - 1))`` per frame, each pixel capped at ``2^0 + ... + 2^t`` (63 for ``t =
5``), with an exact budget: ``sum(m) == N * (s - 1)`` for every frame. The cap is honoured by water-filling
(the capped pixels' excess goes to the others in proportion to their share) and the rounding by largest
remainder. Everything here is a non-differentiable integer map; the gradient is
:mod:`mcd.sampling.dasr_grad`'s job.
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
    order = remainder.argsort(dim=1, descending=True)
    rank = torch.empty_like(order)
    rank.scatter_(1, order, torch.arange(n, device=p.device).expand(b, n))
    m = floor + (rank < deficit[:, None]).double()
    if not (bool((m.sum(1) == total).all()) and float(m.max()) <= cap and float(m.min()) >= 0):
        raise RuntimeError(f"sampling-map normalisation broke its invariant: sums {m.sum(1).tolist()} != "
                           f"{total} or values outside [0, {cap}]")
    return m.to(p.dtype if p.dtype.is_floating_point else torch.float32).reshape(p.shape)


def _water_fill(p: Tensor, total: float, cap: float) -> Tensor:
    """``min(lam * p, cap)`` with, per row, the ``lam`` that makes the row sum to ``total`` (``p > 0``
    everywhere).

    Exact and loop-free: with the shares sorted, if the ``k`` largest are capped then ``lam_k = (total - k
    cap) / (sum of the rest)``; the answer is the smallest ``k`` whose next share is not capped by ``lam_k``.
    """
    ps, _ = p.sort(dim=1, descending=True)
    n = ps.shape[1]
    rest = ps.flip(1).cumsum(1).flip(1)                                        # sum_{j >= k} ps_j
    k = torch.arange(n, device=p.device, dtype=p.dtype)
    ok = (total - k * cap) * ps <= cap * rest                                  # lam_k * ps_k <= cap
    first = ok.double().argmax(dim=1)                          # smallest valid k (ok[:, -1] always holds)
    lam = (total - first.to(p.dtype) * cap) / rest.gather(1, first[:, None]).squeeze(1)
    return torch.minimum(lam[:, None] * p, torch.full_like(p, cap))

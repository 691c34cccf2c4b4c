"""Simulated adaptive render (docs/method.md "Adaptive sampling" steps 2-3; paper Eq. 2, after DASR).

A pixel given ``m`` samples takes, for every set bit ``k`` of ``m``, the pre-rendered independent image
``c_{2^k}`` (``2^k`` samples), so ``i = sum_k c_{2^k} 2^k bit_k(m) / m`` is the average of exactly ``m``
independent samples. The render ``c_1`` that the sampling network saw (buffer ``c1_in``) already spent one
sample per pixel and is blended in by sample count, ``i <- (c_1 + m i) / (1 + m)``, so ``m = 0`` is safe.
"""

from __future__ import annotations

import torch
from torch import Tensor


def stack_names(levels: int) -> list[str]:
    """Buffer names of the binary stack ``c1, c2, ..., c{2^levels}``."""
    return [f"c{2 ** k}" for k in range(levels + 1)]


def stack_buffers(x: dict[str, Tensor | None], levels: int) -> Tensor:
    """The stack ``[B, levels + 1, C, H, W]`` of the renders ``c_{2^k}`` read from a batch dict."""
    names = stack_names(levels)
    missing = [n for n in names if x.get(n) is None]
    if missing:
        raise KeyError(f"the simulated adaptive render needs buffers {names}; missing {missing} "
                       "(the model's required_buffers() lists them; render them into the store)")
    return torch.stack([x[n] for n in names], dim=1)


def sample_sum(m: Tensor, stack: Tensor) -> Tensor:
    """``sum_k c_{2^k} 2^k bit_k(m)`` = the sum of the ``m`` samples a pixel gets, ``[B, C, H, W]``.

    ``m``: integer-valued ``[B, 1, H, W]``; ``stack``: ``[B, K, C, H, W]`` with ``stack[:, k] = c_{2^k}``.
    """
    levels = stack.shape[1]
    if float(m.max()) >= 2 ** levels:
        raise ValueError(f"sampling map holds {int(m.max())} samples but the stack has only {levels} levels "
                         f"(cap {2 ** levels - 1})")
    mi = m.long()
    total = torch.zeros_like(stack[:, 0])
    for k in range(levels):                                   # loop over the <= 6 stack levels, not pixels
        bit = ((mi >> k) & 1).to(stack.dtype)
        total = total + stack[:, k] * (bit * 2 ** k)
    return total


def simulated_render(m: Tensor, stack: Tensor) -> Tensor:
    """The adaptively sampled image ``i`` of Eq. 2 (``0`` where ``m = 0``)."""
    return sample_sum(m, stack) / m.clamp_min(1).to(stack.dtype)


def blend_with_c1(c1: Tensor, m: Tensor, stack: Tensor) -> Tensor:
    """``(c_1 + m i) / (1 + m)``: the ``1 + m`` sample average of a pixel (docs/method.md step 3)."""
    return (c1 + sample_sum(m, stack)) / (1 + m.to(stack.dtype))


__all__ = ["blend_with_c1", "sample_sum", "simulated_render", "stack_buffers", "stack_names"]

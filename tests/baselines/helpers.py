"""Synthetic per-frame buffers for the baselines' unit tests (positive HDR colour, plausible G-buffers)."""

from __future__ import annotations

import torch
from torch import Tensor

STACK = ("c1", "c2", "c4", "c8", "c16", "c32")


def frame(b: int = 1, h: int = 32, w: int = 32, seed: int = 0, t: int | None = None) -> dict[str, Tensor]:
    """One frame's buffers ``[B, C, H, W]`` (or ``[B, T, C, H, W]`` when ``t`` is given)."""
    g = torch.Generator().manual_seed(seed)
    lead = (b,) if t is None else (b, t)

    def rnd(c: int, scale: float = 1.0) -> Tensor:
        return torch.rand(*lead, c, h, w, generator=g) * scale

    normal = torch.nn.functional.normalize(rnd(3) - 0.5, dim=-3)
    x = {k: rnd(3, 2.0) for k in (*STACK, "c1_in", "ref")}
    x.update(depth=rnd(1, 10.0) + 0.1, normal=normal, albedo=rnd(3), motion=torch.zeros(*lead, 2, h, w))
    return x

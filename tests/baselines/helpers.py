"""Synthetic per-frame buffers for the baselines' unit tests (positive HDR colour, plausible G-buffers, a
still camera)."""

from __future__ import annotations

from torch import Tensor

from mcd.data.buffers import BUFFERS
from mcd.data.synthetic import synthetic_frame


def frame(b: int = 1, h: int = 32, w: int = 32, seed: int = 0, t: int | None = None) -> dict[str, Tensor]:
    """One frame's buffers ``[B, C, H, W]`` (or ``[B, T, C, H, W]`` when ``t`` is given), motion zero."""
    return synthetic_frame(BUFFERS, h, w, (b,) if t is None else (b, t), seed, colour_scale=2.0)

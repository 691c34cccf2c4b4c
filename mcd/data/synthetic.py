"""Seeded synthetic frames: every buffer of :mod:`mcd.data.buffers` in its channel count and range, for
what needs model inputs without a store (``mcd.bench --synthetic``, the MAC count of
``mcd.models.complexity``, unit tests). docs/architecture.md ("The store", "Models").
"""

from __future__ import annotations

from collections.abc import Iterable

import torch
from torch import Tensor

from mcd.data.buffers import BUFFERS, BY_NAME, validate_buffers


def synthetic_frame(
    names: Iterable[str],
    height: int,
    width: int,
    lead: tuple[int, ...] = (1,),
    seed: int = 0,
    device: torch.device | str = "cpu",
    colour_scale: float = 1.0,
    depth_scale: float = 10.0,
    motion_px: float = 0.0,
) -> dict[str, Tensor]:
    """Buffers ``names`` as float32 tensors ``[*lead, C, H, W]`` (``lead`` e.g. ``(B,)`` or ``(B, T)``).

    Colour (``c1_in``, ``c<k>``, ``ref``): uniform in ``[0, colour_scale)``; ``depth``: in ``[0.1, 0.1 +
    depth_scale)``; ``normal``: unit vectors; ``albedo``: in ``[0, 1)``; ``motion``: normal with standard
    deviation ``motion_px`` pixels (zeros by default: a still camera). Drawn in table order from one generator
    seeded with ``seed``, so a name's values do not depend on the order of ``names``. On the ``meta`` device
    the tensors have shapes only.
    """
    want = validate_buffers(names)
    out: dict[str, Tensor] = {}
    g = None if torch.device(device).type == "meta" else torch.Generator().manual_seed(seed)
    for name in (n for n in BUFFERS if n in want):
        b = BY_NAME[name]
        shape = (*lead, b.channels, height, width)
        if g is None:
            out[name] = torch.empty(shape, device=device)
            continue
        if name == "normal":
            v = torch.nn.functional.normalize(torch.randn(shape, generator=g, device="cpu"), dim=-3)
        elif name == "motion":
            v = torch.randn(shape, generator=g, device="cpu") * motion_px
        elif name == "depth":
            v = torch.rand(shape, generator=g, device="cpu") * depth_scale + 0.1
        elif b.colour:
            v = torch.rand(shape, generator=g, device="cpu") * colour_scale
        else:  # albedo
            v = torch.rand(shape, generator=g, device="cpu")
        out[name] = v.to(device)
    return out

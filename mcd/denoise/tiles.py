"""Large frames in overlapping tiles under a memory cap (docs/denoise.md, "Tiles").

The activation memory of a model grows with the pixels it sees. :func:`bytes_per_pixel` measures it once: the
summed size of every module's output during one forward pass of a ``PROBE`` x ``PROBE`` input, per pixel (an
upper bound of the peak, since the pass frees most of them as it goes). :func:`tile_size` picks the largest
square tile, a multiple of ``MULTIPLE`` (the U-Nets' stride), whose padded size fits ``--max-memory-mb``; a
frame that fits is one tile. Tiles overlap by ``overlap`` pixels and are blended with weights that ramp
linearly across the overlap, so no seam is a hard edge. A model with temporal state (semantic alignment, RAE,
NTASAD) gets one copy per tile, so each tile carries its own state across the sequence.
"""

from __future__ import annotations

import copy
import math

import torch
from torch import Tensor, nn

PROBE = 64
MULTIPLE = 16


def bytes_per_pixel(model: nn.Module, x: dict[str, Tensor | None]) -> float:
    """Bytes of module outputs per input pixel of one forward pass of ``model`` on ``x`` (module docstring).

    ``x`` holds a small crop of real inputs; the model is reset before and after (its state is not kept).
    The pass runs under plain ``no_grad`` even where the caller is in ``inference_mode``: the CPU inference
    fast paths (docs/inference.md) call fused operators in place of some submodules, whose outputs the hooks
    would then not see.
    """
    with torch.inference_mode(False), torch.no_grad():
        plain = {k: None if v is None else v.clone() for k, v in x.items()}          # not inference tensors
        return _module_output_bytes_per_pixel(model, plain)


def _module_output_bytes_per_pixel(model: nn.Module, x: dict[str, Tensor | None]) -> float:
    total = 0

    def hook(_m: nn.Module, _i: object, out: object) -> None:
        nonlocal total
        for t in out.values() if isinstance(out, dict) else out if isinstance(out, list | tuple) else [out]:
            if isinstance(t, Tensor):
                total += t.numel() * t.element_size()

    handles = [m.register_forward_hook(hook) for m in model.modules()]
    try:
        model.reset()
        model(x)
    finally:
        for h in handles:
            h.remove()
        model.reset()
    inputs = sum(t.numel() * t.element_size() for t in x.values() if isinstance(t, Tensor))
    h, w = next(t for t in x.values() if isinstance(t, Tensor)).shape[-2:]
    return (total + inputs) / (h * w)


def tile_size(per_pixel: float, max_memory_mb: float, overlap: int) -> int:
    """The largest tile side (a multiple of ``MULTIPLE``) whose ``side + 2 * overlap`` square fits the cap."""
    side = int(math.sqrt(max_memory_mb * 2**20 / max(per_pixel, 1e-9))) - 2 * overlap
    side -= side % MULTIPLE
    if side < MULTIPLE:
        need = (MULTIPLE + 2 * overlap) ** 2 * per_pixel / 2**20
        raise ValueError(f"--max-memory-mb={max_memory_mb:g}: too small for even a {MULTIPLE}x{MULTIPLE} "
                         f"tile with {overlap}-pixel overlap (needs about {need:.0f} MB); raise it")
    return side


def grid(length: int, tile: int, overlap: int) -> list[tuple[int, int]]:
    """``(start, stop)`` of tiles along one axis: cores of at most ``tile`` pixels, widened by ``overlap``."""
    if length <= tile + 2 * overlap:
        return [(0, length)]
    n = math.ceil(length / tile)
    out = []
    for k in range(n):
        a, b = k * length // n, (k + 1) * length // n
        out.append((max(a - overlap, 0), min(b + overlap, length)))
    return out


def ramp(start: int, stop: int, length: int, overlap: int) -> Tensor:
    """Blend weights along one axis of a tile: 1 inside, a linear ramp across an overlap with a neighbour."""
    pos = torch.arange(start, stop, dtype=torch.float32)
    w = torch.ones(stop - start)
    if overlap > 0:
        if start > 0:
            w = torch.minimum(w, (pos - start + 1) / (2 * overlap + 1))
        if stop < length:
            w = torch.minimum(w, (stop - pos) / (2 * overlap + 1))
    return w


class TiledModel:
    """Runs ``model`` over a frame in tiles (module docstring); call it like the model; ``reset()`` per
    sequence."""

    def __init__(self, model: nn.Module, height: int, width: int, tile: int, overlap: int):
        self.h, self.w, self.overlap = height, width, overlap
        self.tiles = [(ys, xs) for ys in grid(height, tile, overlap) for xs in grid(width, tile, overlap)]
        stateful = bool(getattr(model, "temporal_state", True)) and len(self.tiles) > 1
        self.models = [copy.deepcopy(model) for _ in self.tiles] if stateful else [model] * len(self.tiles)

    def __len__(self) -> int:
        return len(self.tiles)

    def reset(self) -> None:
        for m in {id(m): m for m in self.models}.values():
            m.reset()

    @torch.inference_mode()
    def __call__(self, x: dict[str, Tensor | None]) -> dict[str, Tensor]:
        if len(self.tiles) == 1:
            return self.models[0](x)
        acc: dict[str, Tensor] = {}
        weight: Tensor | None = None
        for model, ((y0, y1), (x0, x1)) in zip(self.models, self.tiles, strict=True):
            part = {k: None if v is None else v[..., y0:y1, x0:x1] for k, v in x.items()}
            out = model(part)
            wy = ramp(y0, y1, self.h, self.overlap)
            wx = ramp(x0, x1, self.w, self.overlap)
            wt = (wy[:, None] * wx[None, :])
            for k, v in out.items():
                if v.ndim != 4 or v.shape[-2:] != (y1 - y0, x1 - x0):
                    continue  # not a per-pixel image (e.g. a picture of the kernel pool)
                if k not in acc:
                    acc[k] = torch.zeros(*v.shape[:2], self.h, self.w, dtype=torch.float32, device=v.device)
                acc[k][..., y0:y1, x0:x1] += v.float() * wt.to(v.device)
            if weight is None:
                weight = torch.zeros(self.h, self.w)
            weight[y0:y1, x0:x1] += wt
        assert weight is not None
        return {k: v / weight.to(v.device) for k, v in acc.items()}

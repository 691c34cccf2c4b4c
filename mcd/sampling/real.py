"""A real renderer in place of the simulated adaptive render (docs/denoise.md, "Scenes: the real loop").

Inside ``with real_renderer(render_sum):`` every :func:`mcd.sampling.adaptive_render` normalises the sampling
map exactly as in training (``sum(m) == N * (s - 1)``, paper Eq. 1) and then, instead of picking the
pre-rendered images ``c_{2^k}`` of the simulated render (Eq. 2), calls ``render_sum(m)``, which renders ``m``
new samples per pixel with Mitsuba and returns their sum ``[B, 3, H, W]`` (in the network's exposure); the
adaptive image is ``(c_1 + sum) / (1 + m)`` as in :func:`mcd.sampling.blend_with_c1`. The models (rows B-M,
DASR, NTASAD) run unchanged: the paper's pipeline on a real renderer, which the paper itself only simulated.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from contextvars import ContextVar

from torch import Tensor

RenderSum = Callable[[Tensor], Tensor]
_RENDERER: ContextVar[RenderSum | None] = ContextVar("mcd_real_renderer", default=None)


@contextlib.contextmanager
def real_renderer(render_sum: RenderSum) -> Iterator[None]:
    """Make :func:`mcd.sampling.adaptive_render` render its maps with ``render_sum`` inside the block."""
    token = _RENDERER.set(render_sum)
    try:
        yield
    finally:
        _RENDERER.reset(token)


def active_renderer() -> RenderSum | None:
    """The renderer of the enclosing :func:`real_renderer` block, or None (the simulated render)."""
    return _RENDERER.get()

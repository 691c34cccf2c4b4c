"""What ``mcd.denoise`` writes per frame (docs/denoise.md, "Output").

``<out>/<stem>.exr``: the denoised frame, linear HDR in the input's own units (the exposure scale undone);
``<out>/<stem>.png``: a preview (``mcd.core.metrics.to_display`` of the exposure-normalised image); and where
the method has them ``<stem>_sampling_map``, ``<stem>_kernel_map``, ``<stem>_adaptive`` (the adaptive render
``i``), ``<stem>_initial`` (``ī``) as EXR + PNG, drawn as the run directory's samples are
(:func:`mcd.lit.samples.picture`); with a reference (``--scene ... --reference-spp``) ``<stem>_reference``
too, in the same units.

Every file is written atomically (:mod:`mcd.core.atomic_write`): to a hidden temporary file in the same
folder, then renamed over the final name, so a killed run never leaves a half-written file under a final
name, and a symlink named like an output is replaced, never written through (docs/reliability.md, "Denoising
your frames").
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mcd.core.atomic_write import atomic_write, atomic_write_json
from mcd.data.exposure import scale
from mcd.data.exr import write_exr

if TYPE_CHECKING:  # imported where used, so that --help starts fast (docs/architecture.md, "Start-up")
    from torch import Tensor

COLOUR = ("output", "adaptive", "initial", "reference")
MAPS = ("sampling_map", "kernel_map")
#: The summary every run writes beside its frames.
SUMMARY = "denoise.json"


def hwc(t: Tensor) -> np.ndarray:
    """``[1, C, H, W]`` tensor -> ``(H, W, C)`` float32 array."""
    return t.detach()[0].float().permute(1, 2, 0).cpu().numpy()


def frame_files(stem: str) -> list[str]:
    """Every file name :func:`write_frame` may write for the frame ``stem`` (its EXR first)."""
    bases = [stem, *(f"{stem}_{name}" for name in (*COLOUR[1:], *MAPS))]
    return [f"{b}{ext}" for b in bases for ext in (".exr", ".png")]


def write_json(path: Path, content: dict[str, Any]) -> None:
    """``content`` as indented JSON at ``path``, atomically."""
    atomic_write_json(path, content, default=str)


def unexposed(img: np.ndarray, exposure: float) -> np.ndarray:
    """``img`` in the input's own units (divided by ``exposure``; ``img`` itself unchanged), held within
    float32's finite range: a frame near float32's largest values has a tiny exposure (a float32 subnormal,
    :func:`mcd.data.exposure.scale`), and dividing by it must not write an Inf."""
    return np.minimum(scale(img.copy(), 1.0 / exposure), np.finfo(np.float32).max)


def write_frame(out_dir: Path, stem: str, out: dict[str, Tensor], exposure: float) -> list[Path]:
    """Write one frame's outputs (module docstring), each atomically; returns the EXR paths written."""
    from matplotlib.image import imsave

    from mcd.lit.samples import picture

    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name in (*COLOUR, *MAPS):
        if name not in out:
            continue
        img = hwc(out[name])
        base = out_dir / (stem if name == "output" else f"{stem}_{name}")
        exr = base.with_name(base.name + ".exr")
        write_exr(exr, unexposed(img, exposure) if name in COLOUR else img, compress=name not in COLOUR)
        preview = picture(name, img)
        atomic_write(base.with_name(base.name + ".png"), lambda tmp, p=preview: imsave(tmp, p, format="png"))
        written.append(exr)
    return written

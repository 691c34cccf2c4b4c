"""What ``mcd.denoise`` writes per frame (docs/denoise.md, "Output").

``<out>/<stem>.exr``: the denoised frame, linear HDR in the input's own units (the exposure scale undone);
``<out>/<stem>.png``: a preview (``mcd.metrics.to_display`` of the exposure-normalised image); and where the
method has them ``<stem>_sampling_map``, ``<stem>_kernel_map``, ``<stem>_adaptive`` (the adaptive render
``i``), ``<stem>_initial`` (``ī``) as EXR + PNG, drawn as the run directory's samples are
(:func:`mcd.lit.samples.picture`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.image import imsave
from torch import Tensor

from mcd.data.exr import write_exr
from mcd.lit.samples import picture

COLOUR = ("output", "adaptive", "initial")
MAPS = ("sampling_map", "kernel_map")


def hwc(t: Tensor) -> np.ndarray:
    """``[1, C, H, W]`` tensor -> ``(H, W, C)`` float32 array."""
    return t.detach()[0].float().permute(1, 2, 0).cpu().numpy()


def write_frame(out_dir: Path, stem: str, out: dict[str, Tensor], exposure: float) -> list[Path]:
    """Write one frame's outputs (module docstring); returns the EXR paths written."""
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for name in (*COLOUR, *MAPS):
        if name not in out:
            continue
        img = hwc(out[name])
        base = out_dir / (stem if name == "output" else f"{stem}_{name}")
        exr = base.with_name(base.name + ".exr")
        write_exr(exr, img / np.float32(exposure) if name in COLOUR else img, compress=name not in COLOUR)
        imsave(base.with_name(base.name + ".png"), picture(name, img))
        written.append(exr)
    return written

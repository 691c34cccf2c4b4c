"""Intermediate outputs of a few test frames for the reports (benchmark.md "Reports", qualitative strip).

``samples/<scene>/<frame:04d>_<name>.exr`` holds the raw values (linear HDR colour; sample counts; kernel map
in [-1, 1]) and ``.png`` a picture of them: colour through the display transform of ``mcd.metrics``; the
sampling map ``m`` with the viridis colour map over ``[0, max(m)]``; the kernel map's two channels as red
(position along the pool) and green (blend towards the identity kernel), each mapped from [-1, 1] to [0, 1].
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.image import imsave

from mcd.data.exr import write_exr
from mcd.metrics import to_display


def picture(name: str, image: np.ndarray) -> np.ndarray:
    """An ``H x W x 3`` picture in [0, 1] of one sample image (see the module docstring)."""
    if name == "sampling_map":
        m = image[..., 0]
        top = float(m.max())
        return colormaps["viridis"](m / top if top > 0 else m)[..., :3]
    if name == "kernel_map":
        rg = np.clip((image[..., :2] + 1.0) / 2.0, 0.0, 1.0)
        return np.concatenate([rg, np.zeros_like(rg[..., :1])], axis=-1)
    if image.shape[-1] == 1:
        image = np.repeat(image, 3, axis=-1)
    return to_display(image)


def save_samples(folder: Path, frame: int, images: dict[str, np.ndarray]) -> None:
    """Save each ``H x W x C`` image of one frame as EXR and PNG under ``folder``."""
    folder.mkdir(parents=True, exist_ok=True)
    for name, image in images.items():
        stem = f"{frame:04d}_{name}"
        write_exr(folder / f"{stem}.exr", image)
        imsave(folder / f"{stem}.png", picture(name, image))

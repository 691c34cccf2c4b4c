"""Intermediate outputs of a few test frames for the reports (docs/benchmark.md "Reports", qualitative strip).

``samples/<scene>/<frame:04d>_<name>.exr`` holds the raw values (linear HDR colour; sample counts; kernel map
in [-1, 1]) and ``.png`` a picture of them: colour through the display transform of ``mcd.core.metrics``; the
sampling map ``m`` with the viridis colour map over ``[0, max(m)]``; the kernel map's two channels as red
(position along the pool) and green (blend towards the identity kernel), each mapped from [-1, 1] to [0, 1];
the adjusted kernel pool (``kernel_pool``, its ``q`` kernels tiled 16 to a row) with the magma colour map over
``[0, max tap]``. :func:`picture` also draws a kernel map's channels apart (``kernel_index``: ``h[0]`` with
the cividis map; ``identity_weight``: ``(h[1] + 1) / 2`` with magma), as the reports' strips do.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib import colormaps
from matplotlib.image import imsave

from mcd.core.metrics import to_display
from mcd.data.exr import write_exr


def picture(name: str, image: np.ndarray) -> np.ndarray:
    """An ``H x W x 3`` picture in [0, 1] of one sample image (see the module docstring)."""
    if name == "sampling_map":
        m = image[..., 0]
        top = float(m.max())
        return colormaps["viridis"](m / top if top > 0 else m)[..., :3]
    if name == "kernel_map":
        rg = np.clip((image[..., :2] + 1.0) / 2.0, 0.0, 1.0)
        return np.concatenate([rg, np.zeros_like(rg[..., :1])], axis=-1)
    if name == "kernel_index":  # h[0] in [-1, 1]: position along the pool
        return colormaps["cividis"](np.clip((image[..., 0] + 1.0) / 2.0, 0.0, 1.0))[..., :3]
    if name == "identity_weight":  # (h[1] + 1) / 2: 1 = the raw pixel, 0 = the pool kernel
        return colormaps["magma"](np.clip((image[..., 1] + 1.0) / 2.0, 0.0, 1.0))[..., :3]
    if name == "kernel_pool":  # the adjusted pool's kernels (softmax taps), tiled
        k = image[..., 0]
        top = float(k.max())
        return colormaps["magma"](k / top if top > 0 else k)[..., :3]
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

"""Exposure, depth scale and sanitising of colour and G-buffers: what every image goes through before a
network sees it (docs/architecture.md, "The store"; docs/denoise.md, "Frames from disk").

The store reader (:meth:`mcd.data.store.StoreReader.load`) applies these to the benchmark's renders and
``mcd.denoise`` to a user's frames, so that a trained network sees its inputs in the range it was trained on:
colour multiplied by the scene's exposure scale (``auto``: the mean of frame 0's colour brought to
``data.exposure_target``), depth divided by the median first-hit distance of frame 0, then NaN/Inf (and
negative values where they are not meaningful, :data:`mcd.data.buffers.NEGATIVE_OK`) replaced by 0, counting
them.
"""

from __future__ import annotations

import numpy as np

from mcd.data.buffers import NEGATIVE_OK
from mcd.data.exr import sanitise


def auto_exposure(frame0: np.ndarray, target: float) -> float | None:
    """The scale that brings the mean of ``frame0`` (colour, sanitised first) to ``target``; None if black."""
    clean, _ = sanitise(np.asarray(frame0, dtype=np.float32), allow_negative=False)
    mean = float(clean.mean())
    return target / mean if mean > 0 else None


def depth_scale(depth0: np.ndarray) -> float:
    """Median positive first-hit distance of frame 0 (1 when nothing is hit)."""
    d = np.asarray(depth0)
    pos = d[np.isfinite(d) & (d > 0)]
    return float(np.median(pos)) if pos.size else 1.0


def normalise(img: np.ndarray, buffer: str, exposure: float, depth_scale: float,
              colour: bool) -> tuple[np.ndarray, int]:
    """``img`` scaled as a network expects (colour x ``exposure``, ``depth`` / ``depth_scale``), then
    sanitised; returns the image and the number of NaN/Inf/negative values replaced by 0.

    Scales first, then sanitises, so a finite value that overflows float32 when scaled becomes 0, not Inf.
    """
    img = np.array(img, dtype=np.float32)
    if colour:
        with np.errstate(over="ignore", invalid="ignore"):
            img *= np.float32(exposure)
    elif buffer == "depth":
        with np.errstate(over="ignore", invalid="ignore"):
            img /= np.float32(depth_scale)
    return sanitise(img, allow_negative=buffer in NEGATIVE_OK)

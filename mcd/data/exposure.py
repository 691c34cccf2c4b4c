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

import logging
from dataclasses import dataclass

import numpy as np

from mcd.data.buffers import NEGATIVE_OK
from mcd.data.exr import sanitise

log = logging.getLogger(__name__)


#: Values of frame 0 above this are clamped to it before its mean is taken (and counted, and named in a
#: warning): far above any radiance a scene of the benchmark renders, low enough that the mean, and so the
#: exposure, stay finite and non-zero in float32 even for a frame of float32's largest values.
EXPOSURE_CLAMP = 1e8


def auto_exposure(frame0: np.ndarray, target: float, name: str = "frame 0") -> float | None:
    """The scale that brings the mean of ``frame0`` (colour, sanitised first) to ``target``; None if black.

    The mean is accumulated in float64 over values clamped to :data:`EXPOSURE_CLAMP`; how many were clamped
    is logged, naming ``name`` (the file or frame). A float32 mean of a frame holding values near 3e38
    would overflow to inf and give an exposure of 0.
    """
    clean, _ = sanitise(np.asarray(frame0, dtype=np.float32), allow_negative=False)
    clamped = int(np.count_nonzero(clean > EXPOSURE_CLAMP))
    if clamped:
        log.warning("%s: %d of %d values above %g clamped to it for the exposure (a broken render? "
                    "check the file)", name, clamped, clean.size, EXPOSURE_CLAMP)
    mean = float(np.minimum(clean, EXPOSURE_CLAMP).mean(dtype=np.float64))
    return target / mean if mean > 0 else None


#: :func:`input_exposure` clamps values above this multiple of the :data:`OUTLIER_QUANTILE` of frame 0's
#: positive values: a firefly is clamped; a light source covering more than the quantile's share of the frame
#: sets the quantile itself and is kept.
OUTLIER_FACTOR = 10.0
OUTLIER_QUANTILE = 0.999
#: the relative change of the mean above which :func:`input_exposure` warns that outliers would have moved it
OUTLIER_WARN = 0.01


@dataclass(frozen=True)
class FrameExposure:
    """What :func:`measure_exposure` found in one frame: its winsorised and its plain mean (float64), how
    many of its ``size`` values lay above ``bound`` (clamped), and the ``target`` the exposure brings the mean
    to."""

    mean: float
    plain: float
    clamped: int
    size: int
    bound: float
    target: float

    @property
    def exposure(self) -> float:
        return self.target / self.mean

    def warn_outliers(self, name: str) -> None:
        """A warning naming ``name`` when the clamp moved the mean by more than :data:`OUTLIER_WARN`."""
        if self.plain > self.mean * (1 + OUTLIER_WARN):
            log.warning("%s: %d of %d values above %.4g (%g x its %g quantile) clamped for the exposure: "
                        "they would have moved it from x%.4g to x%.4g (fireflies? one exposure holds for "
                        "every frame)", name, self.clamped, self.size, self.bound, OUTLIER_FACTOR,
                        OUTLIER_QUANTILE, self.target / self.mean, self.target / self.plain)


def measure_exposure(frame: np.ndarray, target: float) -> FrameExposure | None:
    """The robust mean of a user's noisy colour ``frame`` (sanitised first) behind :func:`input_exposure`;
    None if black."""
    clean, _ = sanitise(np.asarray(frame, dtype=np.float32), allow_negative=False)
    clean = clean.astype(np.float64)
    positive = clean[clean > 0]
    if not positive.size:
        return None
    bound = float(OUTLIER_FACTOR * np.quantile(positive, OUTLIER_QUANTILE))
    mean = float(np.minimum(clean, bound).mean(dtype=np.float64))
    if mean <= 0:
        return None
    return FrameExposure(mean, float(clean.mean(dtype=np.float64)), int(np.count_nonzero(clean > bound)),
                         clean.size, bound, target)


def input_exposure(frame0: np.ndarray, target: float, name: str = "frame 0",
                   warn: bool = True) -> float | None:
    """The scale that brings a robust mean of ``frame0`` (a user's noisy colour, sanitised first) to
    ``target``; None if black. What ``mcd-denoise`` sets the network's input exposure from (docs/denoise.md,
    "Frames from disk").

    A noisy frame may hold fireflies: one pixel of 1e6 in a 128x128 frame of mean 0.5 multiplies the plain
    mean by about 120, and so darkens every frame of the sequence the network sees by that factor. The mean
    here is winsorised: values above :data:`OUTLIER_FACTOR` times the :data:`OUTLIER_QUANTILE` of the positive
    values are clamped to that bound (:func:`measure_exposure`). On a frame without such outliers it is the
    plain mean of :func:`auto_exposure` (the statistic the training data's exposure comes from). When the
    clamp moves the mean by more than :data:`OUTLIER_WARN`, a warning names ``name``, the values clamped and
    both exposures (``warn=False``: none; :meth:`FrameExposure.warn_outliers` gives it for the frame whose
    exposure is used).

    No absolute clamp (:data:`EXPOSURE_CLAMP`) applies here: the mean is taken in float64, which float32's
    largest values cannot overflow, and a sequence whose values are all above such a clamp (physical units
    of mean 1e9, say) must still reach the network at ``target``: clamped, it would reach it too bright, and
    come out wrong (docs/reliability.md, "Campaign fixes").
    """
    measured = measure_exposure(frame0, target)
    if measured is None:
        return None
    if warn:
        measured.warn_outliers(name)
    return measured.exposure


def depth_scale(depth0: np.ndarray) -> float:
    """Median positive first-hit distance of frame 0 (1 when nothing is hit)."""
    d = np.asarray(depth0)
    pos = d[np.isfinite(d) & (d > 0)]
    return float(np.median(pos)) if pos.size else 1.0


def scale(img: np.ndarray, factor: float) -> np.ndarray:
    """``img`` (float32) times ``factor``, as float32: in place where ``factor`` is a normal float32, else via
    float64 into a new array. Values beyond float32's range become Inf, for the caller to sanitise or clamp.

    The exposure of frames near float32's largest values is about 1e-39, below float32's smallest normal
    number: a process that flushes denormals to zero (``torch.set_flush_denormal``, which CPU training sets,
    :func:`mcd.lit.budget.trainer_kwargs`) reads that float32 as 0, and the frame would reach the network
    black and come back NaN (docs/denoise.md, "Frames from disk"). In float64 it is a normal number.
    """
    info = np.finfo(np.float32)
    with np.errstate(over="ignore", invalid="ignore"):
        if factor == 0 or info.tiny <= abs(factor) <= info.max:
            img *= np.float32(factor)
            return img
        return (img.astype(np.float64) * factor).astype(np.float32)


def normalise(img: np.ndarray, buffer: str, exposure: float, depth_scale: float,
              colour: bool) -> tuple[np.ndarray, int]:
    """``img`` scaled as a network expects (colour x ``exposure``, ``depth`` / ``depth_scale``), then
    sanitised; returns the image and the number of NaN/Inf/negative values replaced by 0.

    Scales first, then sanitises, so a finite value that overflows float32 when scaled becomes 0, not Inf.
    """
    img = np.array(img, dtype=np.float32)
    if colour:
        img = scale(img, exposure)
    elif buffer == "depth":
        with np.errstate(over="ignore", invalid="ignore"):
            img /= np.float32(depth_scale)
    return sanitise(img, allow_negative=buffer in NEGATIVE_OK)

"""Error metrics exactly as ``docs/benchmark.md`` ("Metrics") defines them, and their averaging.

Every function takes linear HDR images as ``H x W x 3`` float arrays (NumPy) and returns a Python float.

- PSNR and SSIM on the display image ``clip((x / (1 + x)) ** (1 / 2.2), 0, 1)`` (Reinhard, then gamma);
  SSIM by scikit-image with ``data_range=1`` and ``channel_axis`` set; values in 0..1 (reports scale by 1e2).
- rMSE (Rousselle et al. 2011): mean of ``(x - ref)^2 / (ref^2 + 1e-2)`` on linear HDR (reports scale by 1e3).
- L_t: mean of ``|(d_t - d_{t-1}) - (ref_t - ref_{t-1})|`` on display images, one value per consecutive pair
  (reports scale by 1e2).
- Averages: per frame, then over the frames of a scene, then over scenes (each scene weighs the same).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

import numpy as np
from skimage.metrics import peak_signal_noise_ratio, structural_similarity

#: PSNR of two identical display images is infinite; it is capped here so that averages stay finite.
PSNR_CAP_DB = 100.0
RMSE_EPS = 1e-2

#: Per-frame metric names, in the order of ``frames.csv``.
FRAME_METRICS = ("psnr", "ssim", "rmse", "lt", "input_psnr", "input_ssim", "input_rmse")
#: Per-frame statistics of a model's internals, present only for the models that have them: the kernel map's
#: identity share and the spread of its kernel index across the frame (KP, ``mcd.lit.module``).
MODEL_METRICS = ("kp_identity", "kp_index_std")


def to_display(x: np.ndarray) -> np.ndarray:
    """Display image of linear HDR ``x``: Reinhard ``x / (1 + x)``, gamma 1/2.2, clipped to [0, 1].

    Negative values (possible in a network's output) map to 0, and ``inf`` maps to 1.
    """
    x = np.maximum(np.asarray(x, dtype=np.float64), 0.0)
    with np.errstate(invalid="ignore"):
        tone = np.where(np.isposinf(x), 1.0, x / (1.0 + x))
    return np.clip(tone ** (1.0 / 2.2), 0.0, 1.0)


def _check_pair(x: np.ndarray, ref: np.ndarray) -> None:
    if x.shape != ref.shape or x.ndim != 3 or x.shape[-1] != 3:
        raise ValueError(f"metrics expect two H x W x 3 images of one shape, got {x.shape} and {ref.shape}")


def psnr(x: np.ndarray, ref: np.ndarray) -> float:
    """PSNR in dB of the display images of ``x`` against ``ref`` (peak 1), capped at ``PSNR_CAP_DB``."""
    _check_pair(x, ref)
    dx, dr = to_display(x), to_display(ref)
    if np.array_equal(dx, dr):
        return PSNR_CAP_DB
    return min(float(peak_signal_noise_ratio(dr, dx, data_range=1.0)), PSNR_CAP_DB)


#: Side of scikit-image's default SSIM window: the smallest image side SSIM accepts.
SSIM_WINDOW = 7


def ssim(x: np.ndarray, ref: np.ndarray) -> float:
    """SSIM (0..1) of the display images, scikit-image with ``data_range=1`` and ``channel_axis=-1``.

    scikit-image's default 7x7 window needs images at least 7 pixels on each side.
    """
    _check_pair(x, ref)
    if min(x.shape[:2]) < SSIM_WINDOW:
        raise ValueError(f"SSIM needs images of at least {SSIM_WINDOW}x{SSIM_WINDOW} pixels, got "
                         f"{x.shape[1]}x{x.shape[0]}")
    return float(structural_similarity(to_display(ref), to_display(x), data_range=1.0, channel_axis=-1))


def rmse(x: np.ndarray, ref: np.ndarray) -> float:
    """Relative MSE on linear HDR: mean over pixels and channels of ``(x - ref)^2 / (ref^2 + 1e-2)``."""
    _check_pair(x, ref)
    x64, r64 = np.asarray(x, dtype=np.float64), np.asarray(ref, dtype=np.float64)
    return float(np.mean((x64 - r64) ** 2 / (r64**2 + RMSE_EPS)))


def temporal_l1(x: np.ndarray, x_prev: np.ndarray, ref: np.ndarray, ref_prev: np.ndarray) -> float:
    """L_t of one consecutive pair: mean ``|(d_t - d_{t-1}) - (ref_t - ref_{t-1})|`` on display images."""
    _check_pair(x, ref)
    _check_pair(x_prev, ref_prev)
    dx = to_display(x) - to_display(x_prev)
    dr = to_display(ref) - to_display(ref_prev)
    return float(np.mean(np.abs(dx - dr)))


def frame_metrics(x: np.ndarray, ref: np.ndarray, prefix: str = "") -> dict[str, float]:
    """PSNR, SSIM and rMSE of one frame, keyed ``{prefix}psnr`` etc."""
    return {f"{prefix}psnr": psnr(x, ref), f"{prefix}ssim": ssim(x, ref), f"{prefix}rmse": rmse(x, ref)}


def _mean(values: Iterable[float]) -> float:
    finite = [v for v in values if v is not None and not math.isnan(v)]
    return float(np.mean(finite)) if finite else math.nan


def aggregate(rows: Iterable[Mapping[str, object]], keys: Iterable[str] = FRAME_METRICS) -> dict[str, object]:
    """Average per-frame rows (each with ``scene`` and metric keys) per scene, then over scenes.

    A NaN value (e.g. ``lt`` on a sequence's first frame, which has no pair) is left out of its scene's mean.
    Returns the over-scene averages keyed by metric, plus ``per_scene: {scene: {metric: mean}}`` and
    ``frames: {scene: count}``.
    """
    keys = tuple(keys)
    by_scene: dict[str, list[Mapping[str, object]]] = {}
    for row in rows:
        by_scene.setdefault(str(row["scene"]), []).append(row)
    if not by_scene:
        raise ValueError("no frames to average: the test set is empty")
    per_scene = {
        scene: {k: _mean(float(r[k]) for r in scene_rows if k in r) for k in keys}
        for scene, scene_rows in by_scene.items()
    }
    out: dict[str, object] = {k: _mean(per_scene[s][k] for s in per_scene) for k in keys}
    out["per_scene"] = per_scene
    out["frames"] = {scene: len(scene_rows) for scene, scene_rows in by_scene.items()}
    return out

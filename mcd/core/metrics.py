"""Error metrics exactly as ``docs/benchmark.md`` ("Metrics") defines them, and their averaging.

Every function takes linear HDR images as ``H x W x 3`` float arrays (NumPy) and returns a Python float.

- PSNR and SSIM on the display image ``clip((x / (1 + x)) ** (1 / 2.2), 0, 1)`` (Reinhard, then gamma);
  SSIM by scikit-image with ``data_range=1`` and ``channel_axis`` set; values in 0..1 (reports scale by 1e2).
- rMSE (Rousselle et al. 2011): mean of ``(x - ref)^2 / (ref^2 + 1e-2)`` on linear HDR (reports scale by 1e3).
- L_t: mean of ``|(d_t - d_{t-1}) - (ref_t - ref_{t-1})|`` on display images, one value per consecutive pair
  (reports scale by 1e2).

Beside the paper's metrics (which stay as they are), docs/benchmark.md ("Metrics") adds:

- FLIP (NVIDIA's ꟻLIP, the ``flip-evaluator`` package): mean LDR-FLIP error of the same display images
  (read as sRGB-encoded), 0 = identical, lower is better; :func:`flip_map` gives the per-pixel map.
- tPSNR: the PSNR of the frame differences, ``10 log10(1 / mean(((d_t - d_{t-1}) - (ref_t - ref_{t-1}))^2))``
  on display images, one value per consecutive pair (the squared counterpart of L_t).
- border gap: PSNR of the outer :data:`BORDER`-pixel frame minus PSNR of the interior, in dB (below 0: the
  border is worse); compare a method's with its input's (``input_border_gap``), which shows how much of the
  gap is the content.
- colour shift: the largest relative difference of a channel's frame mean from the reference's,
  ``max_c |mean(x_c) / mean(ref_c) - 1|`` on linear HDR (0.05 = 5%; NaN for a black reference channel).
- Averages: per frame, then over the frames of a scene, then over scenes (each scene weighs the same).

scikit-image and flip-evaluator are imported on first use, so that importing this module (every command
does) stays fast (docs/architecture.md, "Start-up").
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping

import numpy as np

#: PSNR of two identical display images is infinite; it is capped here so that averages stay finite.
PSNR_CAP_DB = 100.0
RMSE_EPS = 1e-2

#: Width in pixels of the image frame that :func:`border_gap` compares with the interior.
BORDER = 4

#: The paper's per-frame metrics (docs/benchmark.md "Metrics"); every finished run's metrics.json has them.
PAPER_METRICS = ("psnr", "ssim", "rmse", "lt", "input_psnr", "input_ssim", "input_rmse")
#: Metrics this project adds (FLIP, tPSNR, border gap, colour shift; runs before them have none).
ADDED_METRICS = ("flip", "tpsnr", "border_gap", "colour_shift",
                 "input_flip", "input_tpsnr", "input_border_gap")
#: Per-frame metric names, in the order of ``frames.csv``.
FRAME_METRICS = (*PAPER_METRICS, *ADDED_METRICS)
#: Per-frame statistics of a model's internals, present only for the models that have them: the kernel map's
#: identity share and the spread of its kernel index across the frame (KP, ``mcd.lit.module``); the sampling
#: map's spread and outer-ring share (adaptive sampling: :func:`map_spread`, :func:`map_ring_share`).
MODEL_METRICS = ("kp_identity", "kp_index_std", "map_spread", "map_ring_share")
#: The sampling map's outer ring: the pixels within this many of the frame's edge (docs/benchmark.md
#: "Sampling-map health").
MAP_RING = 2
#: A sampling map whose spread (standard deviation over mean, per frame) is below this is collapsed: every
#: pixel gets about the same count, so the run samples uniformly (a constant map's spread is 0; the shipped
#: ``F-cpu-bundle``'s is about 1e-8).
MAP_COLLAPSED = 0.05
#: A sampling map whose outer ring gets more than this many times its share of the frame's pixels is
#: edge-bound (the content of the Cornell box and the Modern Hall explains 1.3-1.5x on a two-pixel ring:
#: docs/method.md "Adaptive sampling" 6).
MAP_EDGE_BOUND = 2.0


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
    from skimage.metrics import peak_signal_noise_ratio

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
    from skimage.metrics import structural_similarity

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


def _psnr_of_mse(mse: float) -> float:
    return PSNR_CAP_DB if mse <= 0 else min(10.0 * math.log10(1.0 / mse), PSNR_CAP_DB)


def temporal_psnr(x: np.ndarray, x_prev: np.ndarray, ref: np.ndarray, ref_prev: np.ndarray) -> float:
    """tPSNR of one consecutive pair: PSNR (peak 1, capped) of ``(d_t - d_{t-1})`` against
    ``(ref_t - ref_{t-1})`` on display images."""
    _check_pair(x, ref)
    _check_pair(x_prev, ref_prev)
    err = (to_display(x) - to_display(x_prev)) - (to_display(ref) - to_display(ref_prev))
    return _psnr_of_mse(float(np.mean(err**2)))


def flip_map(x: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """Per-pixel LDR-FLIP error (``H x W``, 0..1) of the display images of ``x`` against ``ref``."""
    _check_pair(x, ref)
    import flip_evaluator

    err, _, _ = flip_evaluator.evaluate(to_display(ref).astype(np.float32), to_display(x).astype(np.float32),
                                        "LDR", inputsRGB=True, applyMagma=False, computeMeanError=False)
    return np.asarray(err, dtype=np.float32).reshape(x.shape[:2])


def flip(x: np.ndarray, ref: np.ndarray) -> float:
    """Mean LDR-FLIP error of the display images (0 = identical; lower is better)."""
    return float(np.mean(flip_map(x, ref), dtype=np.float64))


def _border_mask(shape: tuple[int, ...], width: int) -> np.ndarray | None:
    """True on the outer ``width``-pixel frame of an ``H x W`` image; None without an interior (a side under
    ``3 * width``)."""
    h, w = shape[:2]
    if min(h, w) < 3 * width:
        return None
    border = np.ones((h, w), dtype=bool)
    border[width:h - width, width:w - width] = False
    return border


def border_psnr(x: np.ndarray, ref: np.ndarray, width: int = BORDER) -> float:
    """PSNR (display images) of the outer ``width``-pixel frame alone, in dB; NaN for an image without an
    interior (a side under ``3 * width``)."""
    _check_pair(x, ref)
    border = _border_mask(x.shape, width)
    if border is None:
        return math.nan
    return _psnr_of_mse(float(np.mean((to_display(x) - to_display(ref))[border] ** 2)))


def border_gap(x: np.ndarray, ref: np.ndarray, width: int = BORDER) -> float:
    """PSNR (display images) of the outer ``width``-pixel frame minus that of the interior, in dB; NaN for an
    image without an interior (a side under ``3 * width``)."""
    _check_pair(x, ref)
    border = _border_mask(x.shape, width)
    if border is None:
        return math.nan
    sq = (to_display(x) - to_display(ref)) ** 2
    return _psnr_of_mse(float(np.mean(sq[border]))) - _psnr_of_mse(float(np.mean(sq[~border])))


def colour_shift(x: np.ndarray, ref: np.ndarray) -> float:
    """``max_c |mean(x_c) / mean(ref_c) - 1|`` over the channels on linear HDR (negative values count as 0);
    NaN where a reference channel is black (its mean is below 1e-8)."""
    _check_pair(x, ref)
    mx = np.maximum(np.asarray(x, dtype=np.float64), 0).reshape(-1, 3).mean(0)
    mr = np.maximum(np.asarray(ref, dtype=np.float64), 0).reshape(-1, 3).mean(0)
    if np.any(mr < 1e-8):
        return math.nan
    return float(np.max(np.abs(mx / mr - 1.0)))


def frame_metrics(x: np.ndarray, ref: np.ndarray, prefix: str = "") -> dict[str, float]:
    """PSNR, SSIM, rMSE, FLIP and border gap of one frame (and its colour shift, unless ``prefix`` is set: a
    noisy input's frame mean is the reference's up to noise), keyed ``{prefix}psnr`` etc."""
    out = {f"{prefix}psnr": psnr(x, ref), f"{prefix}ssim": ssim(x, ref), f"{prefix}rmse": rmse(x, ref),
           f"{prefix}flip": flip(x, ref), f"{prefix}border_gap": border_gap(x, ref)}
    if not prefix:
        out["colour_shift"] = colour_shift(x, ref)
    return out


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


def map_spread(m: np.ndarray) -> float:
    """Standard deviation over mean of a sampling map ``m`` (``H x W``, sample counts) over the frame's
    pixels; NaN when the map holds no sample. Below :data:`MAP_COLLAPSED` the map is collapsed."""
    m = np.asarray(m, dtype=np.float64)
    mean = float(m.mean())
    return float(m.std() / mean) if mean > 0 else math.nan


def map_ring_share(m: np.ndarray, ring: int = MAP_RING) -> float:
    """The share of a sampling map's samples that fall on the frame's outer ring (the pixels within ``ring``
    of an edge) over the ring's share of the pixels: 1 = no edge preference; above :data:`MAP_EDGE_BOUND` the
    map is edge-bound. NaN when the map holds no sample or the frame has no interior."""
    m = np.asarray(m, dtype=np.float64)
    h, w = m.shape
    total = float(m.sum())
    if total <= 0 or min(h, w) <= 2 * ring:
        return math.nan
    inner = float(m[ring:-ring, ring:-ring].sum())
    area = 1.0 - (h - 2 * ring) * (w - 2 * ring) / (h * w)
    return ((total - inner) / total) / area


def map_health(spread: float, ring_share: float) -> str:
    """``collapsed`` (spread below :data:`MAP_COLLAPSED`), ``edge-bound`` (ring share above
    :data:`MAP_EDGE_BOUND`), ``adaptive``, or ``unknown`` (NaN figures)."""
    if math.isnan(spread):
        return "unknown"
    if spread < MAP_COLLAPSED:
        return "collapsed"
    if not math.isnan(ring_share) and ring_share > MAP_EDGE_BOUND:
        return "edge-bound"
    return "adaptive"

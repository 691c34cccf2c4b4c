"""Reference quality per scene (docs/data.md, "Reference quality").

A reference is itself a Monte Carlo render: at a fixed ``data.ref_spp`` an easy scene is clean and a hard one
(``veach-ajar``, lit through a door ajar) is noisier than a good denoiser's output, which then cannot be
scored.
Two independent renders ``a`` and ``b`` of ``s / 2`` samples each estimate the noise of their mean (the
reference at ``s`` spp): their difference holds twice the noise of one, and the mean half of it, so

    PSNR(ref_s) ~= PSNR(a, b) + 10 log10(4)

on the display images the metrics use (docs/benchmark.md "Metrics"; the display transform is smooth, so the
first-order propagation holds while the noise is small). :func:`estimate_psnr` computes it; docs/data.md
compares it with the PSNR of a reference against an independent render of the same spp. Since the noise
variance falls as ``1 / s``, :func:`spp_for_target` turns a pilot estimate into the samples per pixel that
reach ``data.ref_quality.target_db``, capped at ``data.ref_quality.max_spp``.
"""

from __future__ import annotations

import math

import numpy as np

from mcd.core.metrics import PSNR_CAP_DB, to_display

#: 10 log10(4): the mean of two independent halves has a quarter of the noise of their difference.
HALVES_GAIN_DB = 10.0 * math.log10(4.0)


def estimate_psnr(half_a: np.ndarray, half_b: np.ndarray, exposure: float = 1.0) -> float:
    """Estimated display-space PSNR (dB, capped at ``PSNR_CAP_DB``) of the mean of two independent renders of
    equal spp (linear HDR, ``H x W x 3``), after multiplying by ``exposure`` (the store's scene exposure: the
    metrics see exposed images)."""
    if half_a.shape != half_b.shape:
        raise ValueError(f"two renders of one shape expected, got {half_a.shape} and {half_b.shape}")
    # non-finite values become 0, as the store sanitises them at load
    a, b = (np.nan_to_num(h, nan=0.0, posinf=0.0, neginf=0.0) for h in (half_a, half_b))
    diff = to_display(a * exposure) - to_display(b * exposure)
    mse = float(np.mean(diff.astype(np.float64) ** 2))
    if mse <= 0:
        return PSNR_CAP_DB
    return min(10.0 * math.log10(1.0 / mse) + HALVES_GAIN_DB, PSNR_CAP_DB)


def spp_for_target(pilot_spp: int, pilot_db: float, target_db: float, max_spp: int, step: int = 64) -> int:
    """Samples per pixel whose reference reaches ``target_db``, given a pilot reference of ``pilot_spp`` that
    reached ``pilot_db``: ``pilot_spp * 10^((target - pilot) / 10)`` rounded up to a multiple of ``step``
    (and of 2: the reference is two halves), at least ``pilot_spp``, at most ``max_spp``."""
    if pilot_spp < 2 or max_spp < pilot_spp:
        raise ValueError(f"need 2 <= pilot spp ({pilot_spp}) <= max spp ({max_spp})")
    need = pilot_spp * 10.0 ** ((target_db - pilot_db) / 10.0)
    if need <= pilot_spp:
        return int(pilot_spp)
    step = max(2, step + step % 2)
    spp = int(math.ceil(need / step) * step)
    return int(min(max(spp, pilot_spp), max_spp))

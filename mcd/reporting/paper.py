"""The paper's numbers for the reference columns of the tables, read from `mcd.config.methods` (never
retyped).

Units as the paper prints them: PSNR dB, SSIM x1e2, L_t x1e2, rMSE x1e3, GMACs at 1920x1080, params in M.
Keys here follow the run's metrics.json (`macs_g`); `mcd.config.methods` says `gmacs`.
"""

from __future__ import annotations

import math

from mcd.config import methods

_FIELDS = {
    "psnr": "psnr",
    "ssim": "ssim",
    "lt": "lt",
    "rmse": "rmse",
    "macs_g": "gmacs",
    "params_m": "params_m",
}


def _row(row: dict | None, keys: tuple[str, ...]) -> dict[str, float]:
    row = row or {}
    return {k: float(row.get(_FIELDS[k], math.nan)) for k in keys}


def table1(experiment: str) -> dict[str, float]:
    """Table 1's row of an experiment (`unet`, `fastdvdnet`, `rae`, `dasr`, `ntasad`, `F`); NaN: none."""
    entry = methods.BY_EXPERIMENT.get(experiment)
    row = entry.paper if entry is not None else None
    return _row(row, ("psnr", "ssim", "macs_g", "params_m"))


def components(experiment: str) -> dict[str, float]:
    """The component study's row `A`..`M`; NaN when the paper has none."""
    return _row(
        methods.COMPONENTS.get(experiment), ("psnr", "ssim", "lt", "rmse", "macs_g", "params_m")
    )


def switches(experiment: str) -> dict[str, bool]:
    """The component switches that define row `A`..`M` (docs/method.md); {} for other experiments."""
    return dict(methods.COMPONENTS.get(experiment, {}).get("switches", {}))

"""The paper's numbers for the reference columns of the tables, read from `mcd.paper_numbers` (never retyped).

Units as the paper prints them: PSNR dB, SSIM x1e2, L_t x1e2, rMSE x1e3, GMACs at 1920x1080, params in M.
"""

from __future__ import annotations

import math
from typing import Any

TABLE1_KEYS = ("psnr", "ssim", "macs_g", "params_m")
COMPONENT_KEYS = ("psnr", "ssim", "lt", "rmse", "macs_g", "params_m")


def _module() -> Any:
    from mcd import paper_numbers

    return paper_numbers


def table1(experiment: str) -> dict[str, float]:
    """Table 1's row of an experiment (`unet`, `fastdvdnet`, `rae`, `dasr`, `ntasad`, `F`); NaN: none."""
    rows = getattr(_module(), "TABLE1", {})
    row = rows.get(experiment, {})
    return {k: float(row.get(k, math.nan)) for k in TABLE1_KEYS}


def components(experiment: str) -> dict[str, float]:
    """The component study's row `A`..`M`; NaN if none."""
    rows = getattr(_module(), "COMPONENTS", {})
    row = rows.get(experiment, {})
    return {k: float(row.get(k, math.nan)) for k in COMPONENT_KEYS}

"""The paper's published numbers (docs/benchmark.md "The paper's numbers"), as data for the reports and
``python -m mcd.tools.complexity``. Mitsuba scenes, 4 spp, 1920x1080.
"""

from __future__ import annotations

from mcd.models.switches import SWITCHES

#: Table 1: method -> PSNR, SSIM x1e2, GMACs, M params. Keys are ``method.name`` values; "two_stage" is "Ours"
#: (row F of the component study).
TABLE1: dict[str, dict[str, float]] = {
    "unet": {"psnr": 31.91, "ssim": 86.00, "gmacs": 316.52, "params_m": 0.972},
    "fastdvdnet": {"psnr": 32.07, "ssim": 86.02, "gmacs": 1083.5, "params_m": 1.867},
    "rae": {"psnr": 31.96, "ssim": 86.07, "gmacs": 432.61, "params_m": 1.864},
    "dasr": {"psnr": 31.97, "ssim": 86.08, "gmacs": 558.00, "params_m": 1.577},
    "ntasad": {"psnr": 32.13, "ssim": 86.46, "gmacs": 826.11, "params_m": 1.578},
    "two_stage": {"psnr": 33.39, "ssim": 87.65, "gmacs": 478.22, "params_m": 1.285},
}

_COMPONENT_ROWS = """
A 100000 31.92 86.00 2.51 5.58 316.52 0.972
B 110000 32.13 86.81 2.52 5.09 464.87 1.348
C 111000 33.11 87.31 2.27 4.03 526.05 1.471
D 111100 33.29 87.51 2.17 3.79 526.40 1.471
E 111110 33.34 87.56 2.18 3.70 478.54 1.324
F 111111 33.39 87.65 2.16 3.67 478.22 1.285
G 111010 33.22 87.33 2.20 3.89 478.34 1.324
H 111011 33.19 87.36 2.22 3.90 478.02 1.284
I 111101 33.15 87.40 2.22 4.00 525.94 1.432
J 111001 33.14 87.29 2.25 4.06 525.74 1.432
K 110100 32.46 86.94 2.43 4.73 465.07 1.348
L 110010 32.43 86.88 2.43 4.72 439.43 1.269
M 110001 32.39 87.02 2.48 4.68 464.56 1.309
"""



def _components() -> dict[str, dict]:
    rows = {}
    for line in _COMPONENT_ROWS.strip().splitlines():
        name, bits, psnr, ssim, lt, rmse, gmacs, params = line.split()
        rows[name] = {"switches": {s: b == "1" for s, b in zip(SWITCHES, bits, strict=True)},
                      "psnr": float(psnr), "ssim": float(ssim), "lt": float(lt), "rmse": float(rmse),
                      "gmacs": float(gmacs), "params_m": float(params)}
    return rows


#: Component study A-M: switches, PSNR, SSIM x1e2, L_t x1e2, rMSE x1e3, GMACs, M params.
COMPONENTS: dict[str, dict] = _components()


def paper_complexity(experiment: str, method: str | None = None) -> dict[str, float] | None:
    """``{"params_m", "gmacs"}`` the paper reports for an experiment (A-M) or, failing that, for a method of
    Table 1 (by ``method.name``); ``None`` when the paper has no number (e.g. the noisy input, OIDN)."""
    row = COMPONENTS.get(experiment) or TABLE1.get(experiment) or (TABLE1.get(method) if method else None)
    if row is None:
        return None
    return {"params_m": row["params_m"], "gmacs": row["gmacs"]}

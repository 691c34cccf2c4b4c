"""Per-frame PSNR over each test sequence, one plot per scene and one line per method (docs/benchmark.md
"Reports": flicker and drift show there), from each run's `frames.csv`."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.ticker import MaxNLocator  # noqa: E402

from mcd.config.methods import display_name  # noqa: E402
from mcd.reporting.outputs import writes  # noqa: E402
from mcd.reporting.provenance import Provenance  # noqa: E402
from mcd.reporting.runs import Run  # noqa: E402
from mcd.reporting.tables import TABLE1_ROWS, stacked  # noqa: E402

#: Methods drawn: Table 1's and the component chain's first and last rows (A, B, C), at 4 spp.
METHODS = (*TABLE1_ROWS, "A", "B", "C")

#: What it writes in a report's folder (mcd.reporting.outputs).
DIR, = writes("standard", "per_frame")


def per_frame(runs: list[Run]) -> pd.DataFrame:
    """All frames of the 4 spp runs of `METHODS`: experiment, method, scene, frame, psnr, ssim, rmse, lt."""
    return stacked(runs, METHODS, lambda run: run.frames)


def write(runs: list[Run], out_dir: Path, prov: Provenance) -> list[Path]:
    """`per_frame/per_frame.csv` and `per_frame/<scene>_psnr.png`; returns the PNG paths."""
    df = per_frame(runs)
    folder = out_dir / DIR
    folder.mkdir(parents=True, exist_ok=True)
    pngs: list[Path] = []
    if df.empty:
        return pngs
    df.to_csv(folder / "per_frame.csv", index=False)
    for scene, sdf in df.groupby("scene", sort=True):
        fig, ax = plt.subplots(figsize=(9, 4.6))
        for exp in dict.fromkeys(sdf["experiment"]):
            mdf = sdf[sdf["experiment"] == exp].sort_values("frame")
            style = "-" if exp in ("F", "noisy") else "--"
            ax.plot(mdf["frame"], mdf["psnr"], style, marker=".", label=display_name(str(exp)))
        ax.set_xlabel("test frame")
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_ylabel("PSNR (dB)")
        ax.set_title(f"Per-frame PSNR over the test sequence: {scene} (4 spp)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7, ncol=2)
        path = prov.save(fig, folder / f"{scene}_psnr.png", dpi=110)
        pngs.append(path)
    return pngs

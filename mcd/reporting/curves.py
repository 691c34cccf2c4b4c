"""Accuracy against training compute (docs/training.md, "Budgets"): each run's ``curve.csv`` (validation
PSNR after every validation, against optimiser steps and wall-clock seconds) drawn as one line per method, so
that a reader sees which method had converged when its budget ran out and which had not.

Writes ``curves.png`` (two panels: against seconds and against steps) and ``curves.csv`` (every point, with
the run it came from). Runs: the jobs at the Table 1 budget (4 spp) that trained, the default seed of each
experiment (``select.pick``), in the order of Table 1 then the component rows.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from mcd.config.methods import display_name  # noqa: E402
from mcd.reporting.outputs import writes  # noqa: E402
from mcd.reporting.provenance import Provenance  # noqa: E402
from mcd.reporting.runs import Run  # noqa: E402
from mcd.reporting.tables import COMPONENT_ROWS, TABLE1_ROWS, stacked  # noqa: E402

#: What it writes in a report's folder (mcd.reporting.outputs).
CSV, PNG = writes("standard", "curves.csv", "curves.png")


def learning_curves(runs: list[Run]) -> pd.DataFrame:
    """Every curve point of the picked runs: experiment, method, step, seconds, val_psnr, val_ssim, ..."""
    return stacked(runs, (*TABLE1_ROWS, *COMPONENT_ROWS), lambda run: run.curve)


def write(runs: list[Run], out_dir: Path, prov: Provenance) -> list[Path]:
    """``curves.csv`` and ``curves.png`` (nothing when no run has a curve); returns the files written."""
    df = learning_curves(runs)
    if df.empty:
        return []
    csv_path = out_dir / CSV
    df.to_csv(csv_path, index=False)
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.8), sharey=True)
    colours = plt.get_cmap("tab20").colors
    for i, exp in enumerate(dict.fromkeys(df["experiment"])):
        mdf = df[df["experiment"] == exp].sort_values("step")
        style = "-" if exp in ("F", "A") else "--"
        for ax, x in zip(axes, ("seconds", "step"), strict=True):
            ax.plot(mdf[x], mdf["val_psnr"], style, marker=".", color=colours[i % len(colours)],
                    label=display_name(str(exp)))
    axes[0].set_xlabel("training wall-clock seconds")
    axes[1].set_xlabel("optimiser steps")
    axes[0].set_ylabel("validation PSNR (dB)")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    axes[1].legend(fontsize=7, ncol=2)
    fig.suptitle("Accuracy against training compute (a curve still rising at its end has not converged)")
    png = prov.save(fig, out_dir / PNG, dpi=110)
    return [png, csv_path]

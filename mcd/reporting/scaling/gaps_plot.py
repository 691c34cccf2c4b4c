"""``scaling_gaps.png``: every difference of the scaling report as a point with its error bar
(docs/benchmark.md "Scaling report").

The rows of :func:`mcd.reporting.scaling.gaps.table` that have runs on both sides, one line each, grouped by
scale point (smallest first, in the table's order): the paper's ordering (F - NTASAD, F - U-Net), then F's
variants and the diagnostics against their method. PSNR on the left, FLIP on the right (lower is better, so a
negative FLIP difference favours the first method). The bar is ± :data:`BAR_SE` standard errors of the
table's rule, so a bar clear of zero is a difference the seeds resolve, the threshold the notes use
(:mod:`mcd.reporting.scaling.notes`); a hollow point has no standard error (one seed), and is not a result.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from mcd.reporting.outputs import writes  # noqa: E402
from mcd.reporting.provenance import Provenance  # noqa: E402

FILE, = writes("scaling", "scaling_gaps.png")
#: The error bar's half-width in standard errors: the notes' threshold for a resolved difference.
BAR_SE = 2.0
#: The panels: the table's mean and standard-error columns, the axis label.
PANELS = (("PSNR dB", "PSNR se", "PSNR difference (dB), a - b"),
          ("FLIP", "FLIP se", "FLIP difference, a - b (lower favours a)"))


def rows(gaps: pd.DataFrame) -> pd.DataFrame:
    """The rows drawn: those of ``gaps`` with a PSNR difference (runs on both sides), in the table's order."""
    return gaps[gaps["PSNR dB"].notna()].reset_index(drop=True)


def write(gaps: pd.DataFrame, out_dir: Path, prov: Provenance) -> Path | None:
    """Write ``scaling_gaps.png`` from the differences table (None, and nothing written, without a row that
    has runs on both sides)."""
    drawn = rows(gaps)
    if drawn.empty:
        return None
    labels = [f"{d} x {int(s)}: {diff}" for d, s, diff in zip(drawn["data"], drawn["steps"],
                                                             drawn["difference"], strict=True)]
    n = len(drawn)
    height = 1.6 + 0.27 * n
    fig, axes = plt.subplots(1, len(PANELS), figsize=(13.0, height), sharey=True, squeeze=False)
    y = list(range(n))[::-1]  # the table's first row on top
    point = list(zip(drawn["data"], drawn["steps"], strict=True))
    for ax, (mean, se, label) in zip(axes[0], PANELS, strict=True):
        for i in range(n):
            m, e = float(drawn.at[i, mean]), float(drawn.at[i, se])
            if math.isnan(m):
                continue
            has_se = not math.isnan(e)
            ax.errorbar(m, y[i], xerr=BAR_SE * e if has_se else None, fmt="o", ms=4, capsize=2,
                        color="tab:blue", markerfacecolor="tab:blue" if has_se else "white")
        ax.axvline(0.0, color="black", linewidth=0.8)
        for i in range(1, n):  # a rule between scale points
            if point[i] != point[i - 1]:
                ax.axhline(y[i] + 0.5, color="grey", linewidth=0.5, alpha=0.6)
        ax.grid(True, axis="x", alpha=0.3)
        ax.set_xlabel(label)
    axes[0][0].set_yticks(y, labels, fontsize=7)
    axes[0][0].set_ylim(-0.7, n - 0.3)
    title = (f"Differences at each scale point (scaling_gaps.csv): bars ± {BAR_SE:g} standard errors of the "
             "table's rule (clear of zero: resolved by the seeds); hollow: one seed, no standard error.")
    fig.suptitle("\n".join(textwrap.wrap(title, 150)), fontsize=9)
    fig.subplots_adjust(left=0.36, right=0.98, top=1 - 0.55 / height, wspace=0.08)
    return prov.save(fig, out_dir / FILE, dpi=110)

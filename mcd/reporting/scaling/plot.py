"""``scaling.png``: PSNR and FLIP against optimiser steps (docs/benchmark.md "Scaling report").

One column of panels per data profile (smallest first), PSNR above and FLIP below, the steps on a log axis;
one line per method of the study (:data:`mcd.reporting.scaling.grid.STUDY`, each in its own colour in every
report) through its cells' means, and the band of each cell's seeds
(:func:`mcd.reporting.scaling.grid.band_rule`: mean ± standard error from three seeds, the range with two,
none with one). The dotted line of each method in the PSNR panels is its fit
(:mod:`mcd.reporting.scaling.fit`), drawn out to :data:`mcd.reporting.scaling.fit.HORIZON` times the largest
budget of its profile. Each profile has its own test scenes, so the panels share no y axis. The variants of F
and the diagnostics are read against their method, not along the steps: ``scaling_gaps.png``
(:mod:`mcd.reporting.scaling.gaps_plot`).
"""

from __future__ import annotations

import textwrap
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from matplotlib.ticker import NullFormatter  # noqa: E402

from mcd.config.methods import display_name  # noqa: E402
from mcd.reporting.outputs import writes  # noqa: E402
from mcd.reporting.provenance import Provenance  # noqa: E402
from mcd.reporting.scaling import gaps_plot  # noqa: E402
from mcd.reporting.scaling.fit import HORIZON, fit_log_steps  # noqa: E402
from mcd.reporting.scaling.grid import SE_BAND_MIN_SEEDS, STUDY, Grid, order  # noqa: E402

FILE, = writes("scaling", "scaling.png")
#: The rows of panels: score, axis label.
ROWS = (("psnr", "PSNR (dB), higher is better"), ("flip", "FLIP, lower is better"))


def write(grid: Grid, cells: pd.DataFrame, out_dir: Path, prov: Provenance) -> Path | None:
    """Write ``scaling.png`` (None, and nothing written, without cells of the study's methods)."""
    experiments = order(set(cells["experiment"]) & set(STUDY))
    if not experiments:
        return None
    data = grid.data
    width = max(4.2 * len(data), 6.0)
    fig, axes = plt.subplots(len(ROWS), len(data), figsize=(width, 8.0), squeeze=False, sharex="col")
    colours = plt.get_cmap("tab10").colors
    colour = {e: colours[STUDY.index(e)] for e in experiments}
    for col, d in enumerate(data):
        at = cells[cells["data"] == d]
        largest = float(at["steps"].max())
        for exp in experiments:
            c = at[at["experiment"] == exp].sort_values("steps")
            if c.empty:
                continue
            for row, (score, _) in enumerate(ROWS):
                ax = axes[row][col]
                ax.plot(c["steps"], c[f"{score} mean"], "-", marker="o", ms=4, color=colour[exp],
                        label=display_name(exp))
                if (c["n"] > 1).any():
                    ax.fill_between(c["steps"], c[f"{score} lo"], c[f"{score} hi"], color=colour[exp],
                                    alpha=0.18, linewidth=0)
                if score == "psnr":
                    f = fit_log_steps(dict(zip(c["steps"], c["psnr mean"], strict=True)))
                    if f is not None:
                        xs = np.geomspace(min(f.budgets), HORIZON * largest, 50)
                        ax.plot(xs, [f.at(x) for x in xs], ":", color=colour[exp], linewidth=1)
        budgets = sorted(int(s) for s in at["steps"].unique())
        for row, (_, label) in enumerate(ROWS):
            ax = axes[row][col]
            ax.set_xscale("log")
            ax.set_xticks(budgets, [f"{b:g}" for b in budgets])
            ax.xaxis.set_minor_formatter(NullFormatter())
            ax.grid(True, which="both", alpha=0.3)
            ax.set_xlabel("optimiser steps (log axis)")
            if col == 0:
                ax.set_ylabel(label)
        n = grid.train_scene_count(d)
        axes[0][col].set_title(f"data {d} ({n} training scene{'s' if n != 1 else ''})")
    handles, labels = axes[0][0].get_legend_handles_labels()
    for ax in axes[0][1:]:
        for h, lab in zip(*ax.get_legend_handles_labels(), strict=True):
            if lab not in labels:
                handles.append(h)
                labels.append(lab)
    title = (f"Error against optimiser steps at 4 spp. Bands: mean ± standard error over seeds (n >= "
             f"{SE_BAND_MIN_SEEDS}), the seeds' range (n = 2), none (n = 1). Dotted: the fit PSNR = a + b "
             f"log10(steps), drawn to {HORIZON:g}x the largest budget. Variants and diagnostics: "
             f"{gaps_plot.FILE}.")
    fig.suptitle("\n".join(textwrap.wrap(title, int(width * 72 / (9 * 0.55)))), fontsize=9, y=0.99)
    fig.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.925), ncol=len(labels), fontsize=8,
               frameon=False)  # one row between the title and the panels, clear of every curve
    fig.subplots_adjust(left=0.8 / width, right=1 - 0.3 / width, top=0.86, hspace=0.3, wspace=0.3)
    return prov.save(fig, out_dir / FILE, dpi=110)

"""The spp figure (docs/benchmark.md "Reports"): PSNR, SSIM, rMSE, L_t, FLIP and tPSNR against the budget,
one line per method, as PNG and CSV."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from mcd.config.methods import (  # noqa: E402
    BY_EXPERIMENT,
    CATALOGUE,
    display_name,  # noqa: E402
)
from mcd.reporting.outputs import writes  # noqa: E402
from mcd.reporting.provenance import Provenance  # noqa: E402
from mcd.reporting.runs import Run  # noqa: E402
from mcd.reporting.select import metric, pick, run_label  # noqa: E402
from mcd.reporting.tables import COMPONENT_ROWS  # noqa: E402

PANELS = (
    ("psnr", 1.0, "PSNR (dB)"),
    ("ssim", 1e2, "SSIM x1e2"),
    ("rmse", 1e3, "rMSE x1e3"),
    ("lt", 1e2, "L_t x1e2"),
    ("flip", 1e2, "FLIP x1e2"),
    ("tpsnr", 1.0, "tPSNR (dB)"),
)

#: What it writes in a report's folder (mcd.reporting.outputs).
CSV, PNG = writes("standard", "spp.csv", "spp.png")


def spp_frame(runs: list[Run], root: Path | None = None) -> pd.DataFrame:
    """One row per (experiment, budget) with a finished or failed run, preferring the spp sweep's jobs.

    Where a method with a ``stand_in`` (mcd.config.methods: the U-Net is row A's network, docs/baselines.md)
    has no finished run at a budget, that experiment's run stands in and its ``source`` names it, as in Table
    1.
    """
    keys = {(r.experiment, r.budget) for r in runs if r.budget is not None and r.transfer is None}
    ran = {exp for exp, _ in keys}
    for m in CATALOGUE:  # the stand-in fills the gaps of a method that ran at some budget
        if m.stand_in is not None and m.experiment in ran:
            keys |= {(m.experiment, b) for exp, b in keys if exp == m.stand_in}
    rows = []
    for exp, budget in sorted(keys):
        run = pick(runs, exp, budget, prefer_sweep="spp")
        other = BY_EXPERIMENT[exp].stand_in if exp in BY_EXPERIMENT else None
        stand_in = other is not None and (run is None or run.status != "ok")
        if stand_in:
            run = pick(runs, other, budget, prefer_sweep="ablation")
        row = {"method": display_name(exp), "experiment": exp, "source": other if stand_in else exp,
               "budget": budget}
        row.update({key: metric(run, key, scale) for key, scale, _ in PANELS})
        row["status"] = run.status if run is not None else "not run"
        row["run"] = run_label(run, root)
        rows.append(row)
    return pd.DataFrame(
        rows,
        columns=["method", "experiment", "source", "budget", *(k for k, _, _ in PANELS), "status", "run"],
    )


def write(runs: list[Run], out_dir: Path, prov: Provenance, root: Path | None = None) -> pd.DataFrame:
    """`spp.csv` and `spp.png` (x: average spp, log2 axis; one budget only: a point)."""
    df = spp_frame(runs, root)
    df.to_csv(out_dir / CSV, index=False)
    fig, axes = plt.subplots(1, len(PANELS), figsize=(4 * len(PANELS), 4.6))
    # the figure shows Table 1's methods (the component rows other than F are single 4 spp points: spp.csv)
    ok = df[(df["status"] == "ok") & ~df["experiment"].isin([r for r in COMPONENT_ROWS if r != "F"])]
    colours = plt.get_cmap("tab10").colors
    for ax, (key, _, label) in zip(axes, PANELS, strict=True):
        for i, (exp, group) in enumerate(ok.groupby("experiment", sort=True)):
            group = group.sort_values("budget")
            ax.plot(
                group["budget"], group[key], marker="o", color=colours[i % 10], label=display_name(str(exp))
            )
        ax.set_xscale("log", base=2)
        ax.set_xlabel("average spp")
        ax.set_title(label)
        ax.grid(True, alpha=0.3)
    if ok.empty:
        fig.suptitle("spp sweep: no finished runs")
    else:
        axes[-1].legend(fontsize=7)
        fig.suptitle("Error against sample budget (lower rMSE / L_t / FLIP is better)")
    prov.save(fig, out_dir / PNG, sweep_names=["spp"])
    return df

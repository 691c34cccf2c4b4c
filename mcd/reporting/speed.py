"""Speed against error (docs/benchmark.md "Reports"): ms per frame from `python -m mcd.bench`'s CSV against
PSNR and rMSE of the 4 spp runs, one point per method and device (its fastest inference path)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402

from mcd.methods import display_name  # noqa: E402
from mcd.reporting.provenance import Provenance  # noqa: E402
from mcd.reporting.runs import Run  # noqa: E402
from mcd.reporting.select import metric, pick  # noqa: E402
from mcd.reporting.tables import COMPONENT_ROWS, TABLE1_BUDGET  # noqa: E402


def best_paths(bench: pd.DataFrame) -> pd.DataFrame:
    """Per method and device, the fastest measured path at the largest resolution measured on that device."""
    ok = bench[pd.to_numeric(bench["ms_median"], errors="coerce").notna()].copy()
    if ok.empty:
        return ok
    ok["ms_median"] = ok["ms_median"].astype(float)
    ok["pixels"] = ok["height"].astype(int) * ok["width"].astype(int)
    ok = ok[ok["pixels"] == ok.groupby("device")["pixels"].transform("max")]
    return ok.sort_values("ms_median").groupby(["method", "device"], as_index=False).first()


def speed_frame(runs: list[Run], bench: pd.DataFrame) -> pd.DataFrame:
    """The points of the plot: method, device, path, resolution, ms, PSNR, rMSE x1e3."""
    rows = []
    for _, b in best_paths(bench).iterrows():
        exp = str(b["method"])
        prefer = "ablation" if exp in COMPONENT_ROWS and exp != "F" else "baselines"
        run = pick(runs, exp, TABLE1_BUDGET, prefer_sweep=prefer)
        if run is None or run.status != "ok":
            continue
        rows.append(
            {
                "method": display_name(exp),
                "experiment": exp,
                "device": b["device"],
                "dtype": b["dtype"],
                "compiled": b["compiled"],
                "height": int(b["height"]),
                "width": int(b["width"]),
                "ms_median": float(b["ms_median"]), "bench_model": str(b.get("model", "?")),
                "psnr": metric(run, "psnr"),
                "rmse": metric(run, "rmse", 1e3),
            }
        )
    return pd.DataFrame(rows)


def write(runs: list[Run], bench_csv: Path | None, out_dir: Path, prov: Provenance) -> pd.DataFrame:
    """`speed_vs_error.png` and `speed_vs_error.csv` (the plotted points)."""
    bench = pd.read_csv(bench_csv) if bench_csv is not None and bench_csv.is_file() else None
    df = speed_frame(runs, bench) if bench is not None else pd.DataFrame()
    df.to_csv(out_dir / "speed_vs_error.csv", index=False)
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    for ax, key, label in (
        (axes[0], "psnr", "PSNR (dB), higher is better"),
        (axes[1], "rmse", "rMSE x1e3, lower is better"),
    ):
        for device, ddf in df.groupby("device") if not df.empty else []:
            ax.scatter(
                ddf["ms_median"], ddf[key], label=str(device), marker="o" if "cpu" in str(device) else "s"
            )
            for _, r in ddf.iterrows():
                path = f"{r['width']}x{r['height']} {r['dtype']}{' compiled' if r['compiled'] else ''}"
                ax.annotate(
                    f"{r['method']} ({path})",
                    (r["ms_median"], r[key]),
                    fontsize=6,
                    xytext=(3, 3),
                    textcoords="offset points",
                )
        ax.set_xscale("log")
        ax.set_xlabel("median ms per frame (log)")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    if df.empty:
        why = "no bench CSV given" if bench is None else "no method has both a bench row and a finished run"
        fig.suptitle(f"Speed against error: nothing to plot ({why}; run python -m mcd.bench)")
    else:
        axes[0].legend(fontsize=8)
        profiles = ", ".join(sorted(set(df["bench_model"])))
        fig.suptitle(
            f"Speed (largest resolution per device, fastest path per method; {bench_csv}, capacity profile "
            f"{profiles}) against error (4 spp runs: {prov.config_groups})",
            fontsize=9,
        )
    prov.save(fig, out_dir / "speed_vs_error.png")
    return df

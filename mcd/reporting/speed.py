"""Speed against error (docs/benchmark.md "Reports"): one point per method of Table 1, its latency and its
error measured on the same model: the architecture and capacity profile of the 4-spp run that Table 1 shows,
at the resolution of that run's test frames.

- ``speed_vs_error.csv/.png``: for each run, its model is built again from the run's own config
  (``resolved_config.yaml``, else ``.hydra/config.yaml``: method, capacity profile, budget) and timed by
  :func:`mcd.models.latency.alternated_ms` (CPU, fp32, eager, batch 1, the test frames' ``data.width`` x
  ``data.height``, scaled down, aspect kept, to at most :data:`MAX_TIMED_SIDE` pixels a side, which bounds
  the memory timing takes), in this process, the models in turn, one frame each per round, so every point's
  time comes from one machine and the same rounds of its load; PSNR and rMSE are the run's own. The CSV
  (``height`` and ``width`` timed, ``test_size`` the run's own) and the figure's title state the capacity
  profile(s), the resolution timed, any cap, the path and the machine. The noisy input has no network and no
  point.
- ``speed_bench.csv`` (when a bench CSV of ``python -m mcd.bench`` is given): that CSV's fastest path per
  method and device at its largest resolution, under the bench's own capacity profile and resolution (often
  the paper's capacity): a separate latency table, not paired with this report's errors.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pandas as pd  # noqa: E402
from omegaconf import OmegaConf  # noqa: E402

from mcd.config.methods import BY_EXPERIMENT, display_name  # noqa: E402
from mcd.reporting.outputs import writes  # noqa: E402
from mcd.reporting.provenance import Provenance  # noqa: E402
from mcd.reporting.runs import Run, read_table  # noqa: E402
from mcd.reporting.select import metric, pick  # noqa: E402
from mcd.reporting.tables import COMPONENT_ROWS, TABLE1_BUDGET, table1_experiments  # noqa: E402

#: The path every report point is timed on (:func:`mcd.models.latency.alternated_ms`).
PATH = "CPU fp32 eager"
#: Experiments without a network to time.
NO_NETWORK = ("noisy",)
#: The largest side a run's model is timed at; a larger test frame is timed scaled down to it.
MAX_TIMED_SIDE = 1024

#: What it writes in a report's folder (mcd.reporting.outputs).
CSV, PNG, BENCH_CSV = writes("standard", "speed_vs_error.csv", "speed_vs_error.png", "speed_bench.csv")


def timed_size(height: int, width: int) -> tuple[int, int]:
    """``(height, width)`` scaled down, aspect kept, so that neither side exceeds :data:`MAX_TIMED_SIDE`."""
    scale = min(1.0, MAX_TIMED_SIDE / max(height, width))
    return max(1, round(height * scale)), max(1, round(width * scale))


#: The columns of a bench CSV (``python -m mcd.bench``) that :func:`best_paths` reads.
BENCH_COLUMNS = ("method", "device", "height", "width", "ms_median")


def bench_problem(bench_csv: Path | None) -> str | None:
    """What makes ``bench_csv`` (``mcd.report --bench``) unusable, naming it, else None (also when it is not
    a file: the report then has no ``speed_bench.csv``): not a readable CSV, a column of
    :data:`BENCH_COLUMNS` missing, or a height or width that is not a whole number (one ended the report in
    a traceback after its tables), or a latency that is not a positive finite number (``-5`` was the fastest
    path of ``speed_bench.csv``)."""
    if bench_csv is None or not bench_csv.is_file():
        return None
    bench, why = read_table(bench_csv, BENCH_COLUMNS)
    if bench is None:
        return f"--bench {bench_csv}: {why}"
    for col in ("height", "width"):
        values = pd.to_numeric(bench[col], errors="coerce")
        if values.isna().any() or (values % 1 != 0).any():
            return f"--bench {bench_csv}: a {col} that is not a whole number"
    ms = pd.to_numeric(bench["ms_median"], errors="coerce").dropna()  # empty: a path that failed to run
    if not ((ms > 0) & ms.map(math.isfinite)).all():  # a negative latency was the fastest path
        return f"--bench {bench_csv}: an ms_median that is not a positive finite number of milliseconds"
    return None


def best_paths(bench: pd.DataFrame) -> pd.DataFrame:
    """Per method and device, the fastest measured path at the largest resolution measured on that device."""
    ok = bench[pd.to_numeric(bench["ms_median"], errors="coerce").notna()].copy()
    if ok.empty:
        return ok
    ok["ms_median"] = ok["ms_median"].astype(float)
    ok["pixels"] = ok["height"].astype(int) * ok["width"].astype(int)
    ok = ok[ok["pixels"] == ok.groupby("device")["pixels"].transform("max")]
    return ok.sort_values("ms_median").groupby(["method", "device"], as_index=False).first()


def run_config(run: Run) -> dict:
    """The run's composed config: ``resolved_config.yaml`` where the run has one, else its
    ``.hydra/config.yaml``."""
    return run.resolved if run.resolved is not None else run.config


def capacity(run: Run) -> str:
    """The run's capacity profile (the config group's choice; ``?`` where the run does not record it)."""
    return run.choices.get("capacity") or "?"  # mcd.reporting.runs.load_run reads an older run's `model`


def config_size(cfg) -> tuple[int, int]:
    """``(data.height, data.width)`` of a run's config (0 where it has none)."""
    return tuple(int(OmegaConf.select(cfg, f"data.{k}", default=0) or 0) for k in ("height", "width"))


def not_timed(err: Exception) -> str:
    """A row's status where its model could not be built or timed: the error's type and first line."""
    return f"not timed: {type(err).__name__}: {(str(err).splitlines() or [''])[0]}"


def run_timer(run: Run) -> tuple[object, int, int]:
    """``(timer, height, width)``: the run's own model, built again from its config and prepared for timing
    at its test frames' resolution capped by :func:`timed_size` (``height`` and ``width`` are the size to
    time; a :class:`mcd.models.latency.FrameTimer`, or in its place the reason it cannot be timed, e.g. OIDN
    without pyoidn)."""
    from mcd.models import build
    from mcd.models.latency import FrameTimer

    cfg = OmegaConf.create(run_config(run))
    height, width = config_size(cfg)
    if not height or not width:
        return "not timed: the run's config has no data.height and data.width", height, width
    height, width = timed_size(height, width)
    try:
        return FrameTimer(build(cfg), height, width), height, width
    except Exception as err:  # a model that cannot be timed is a row that says why, not a crash
        return not_timed(err), height, width


def speed_frame(runs: list[Run]) -> pd.DataFrame:
    """The points of the plot: one per Table 1 experiment with a finished 4-spp run (the run Table 1 shows,
    row A's for a U-Net without a job of its own), its model's latency and its errors; the models are timed
    in turn (:func:`mcd.models.latency.alternated_ms`)."""
    import torch

    from mcd.core.machine import device_name
    from mcd.models.latency import FrameTimer, alternated_ms

    machine = device_name(torch.device("cpu"))
    chosen = []
    for exp in table1_experiments({r.experiment for r in runs}):
        if exp in NO_NETWORK:
            continue
        prefer = "ablation" if exp in COMPONENT_ROWS and exp != "F" else "baselines"
        run, label = pick(runs, exp, TABLE1_BUDGET, prefer_sweep=prefer), display_name(exp)
        other = BY_EXPERIMENT[exp].stand_in if exp in BY_EXPERIMENT else None
        if other is not None and (run is None or run.status != "ok"):  # as Table 1: the U-Net is row A
            label = f"{display_name(exp)} (row {other})"
            run, exp = pick(runs, other, TABLE1_BUDGET, prefer_sweep="ablation"), other
        if run is not None and run.status == "ok":
            chosen.append((run, label, exp, *run_timer(run)))
    timers = [t for _, _, _, t, _, _ in chosen if isinstance(t, FrameTimer)]
    measured = iter(alternated_ms(timers))
    rows = []
    for run, label, exp, timer, height, width in chosen:
        ms, status = math.nan, timer
        if isinstance(timer, FrameTimer):
            found = next(measured)
            if isinstance(found, Exception):
                status = not_timed(found)
            else:
                ms, status = found, "ok"
        run_h, run_w = config_size(OmegaConf.create(run_config(run)))
        rows.append(
            {
                "method": label,
                "experiment": exp,
                "capacity": capacity(run),
                "height": height,
                "width": width,
                "test_size": f"{run_w}x{run_h}",
                "path": PATH,
                "ms_median": ms,
                "psnr": metric(run, "psnr"),
                "rmse": metric(run, "rmse", 1e3),
                "device_name": machine,
                "status": status,
                "run": str(run.path.name),
            }
        )
    return pd.DataFrame(rows)


def _title(df: pd.DataFrame, prov: Provenance) -> str:
    timed = df[df["status"] == "ok"]
    if timed.empty:
        return "Speed against error: nothing to plot (no finished 4-spp run whose model could be timed)"
    caps = ", ".join(sorted(set(timed["capacity"])))
    sizes = ", ".join(sorted({f"{w}x{h}" for w, h in zip(timed["width"], timed["height"], strict=True)}))
    capped = sorted(set(timed["test_size"]) - {f"{w}x{h}" for w, h in zip(timed["width"], timed["height"],
                                                                             strict=True)})
    where = (f" (its test frames; {', '.join(capped)} timed scaled down to at most {MAX_TIMED_SIDE} pixels "
             "a side)") if capped else " (its test frames)"
    return (f"Speed against error, each point one run's own model: capacity {caps}, {sizes}{where}, {PATH}, "
            f"{timed['device_name'].iloc[0]}; error: 4-spp runs ({prov.config_groups})")


def write(runs: list[Run], bench_csv: Path | None, out_dir: Path, prov: Provenance) -> list[Path]:
    """``speed_vs_error.png`` and ``speed_vs_error.csv`` (the plotted points), and ``speed_bench.csv`` from
    ``bench_csv`` when it is a file (see the module docstring); returns the files written."""
    df = speed_frame(runs)
    written = [out_dir / PNG, out_dir / CSV]
    df.to_csv(out_dir / CSV, index=False)
    if bench_csv is not None and bench_csv.is_file():
        best_paths(pd.read_csv(bench_csv)).to_csv(out_dir / BENCH_CSV, index=False)
        written.append(out_dir / BENCH_CSV)
    timed = df[df["status"] == "ok"] if not df.empty else df
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    for ax, key, label in (
        (axes[0], "psnr", "PSNR (dB), higher is better"),
        (axes[1], "rmse", "rMSE x1e3, lower is better"),
    ):
        if not timed.empty:
            ax.scatter(timed["ms_median"], timed[key])
            for _, r in timed.iterrows():
                ax.annotate(str(r["method"]), (r["ms_median"], r[key]), fontsize=7, xytext=(3, 3),
                            textcoords="offset points")
        ax.set_xscale("log")
        ax.set_xlabel("median ms per frame (log)")
        ax.set_ylabel(label)
        ax.grid(True, alpha=0.3)
    empty = "Speed against error: no finished 4-spp run"
    fig.suptitle(_title(df, prov) if not df.empty else empty, fontsize=8)
    prov.save(fig, out_dir / PNG)
    return written

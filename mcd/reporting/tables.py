"""Table 1 (methods at 4 spp), the component table (A-M) and the transfer table (docs/benchmark.md "Reports"),
as markdown and CSV, with the paper's numbers in adjacent columns (read from `mcd.config.methods`)."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from pathlib import Path

import pandas as pd

from mcd.config.methods import BY_EXPERIMENT, COMPONENTS, TABLE1_ROWS, TABLE1_VARIANTS, display_name
from mcd.models.switches import SWITCHES
from mcd.reporting import paper
from mcd.reporting.finding import Finding, render
from mcd.reporting.outputs import writes
from mcd.reporting.runs import Run
from mcd.reporting.select import metric, pick, run_label, train_scene_metric, write_table

#: The component study's rows A-M, in the paper's order (:data:`mcd.config.methods.COMPONENTS`).
COMPONENT_ROWS = tuple(COMPONENTS)
#: The chain that adds one component at a time (docs/method.md): B adds AS to A, C adds KP, D PP, E FG, F SA.
STEPS = ("A", "B", "C", "D", "E", "F")
TABLE1_BUDGET = 4.0

#: What it writes in a report's folder (mcd.reporting.outputs).
#: ``<stem>.csv`` and ``<stem>.md`` of each table (:func:`mcd.reporting.select.write_table`).
STEMS = ("table1", "components", "transfer")
FILES = writes("standard", *(f"{stem}.{ext}" for stem in STEMS for ext in ("md", "csv")))


def stacked(runs: list[Run], experiments: Iterable[str],
            table: Callable[[Run], pd.DataFrame | None]) -> pd.DataFrame:
    """``table(run)`` of each experiment's finished run at the Table 1 budget (``pick``: default seed, the
    ablation sweep for component rows, else baselines) stacked with ``experiment`` and ``method`` columns
    first; experiments without a finished run or a table are left out."""
    parts = []
    for exp in dict.fromkeys(experiments):
        prefer = "ablation" if exp in COMPONENT_ROWS else "baselines"
        run = pick(runs, exp, TABLE1_BUDGET, prefer_sweep=prefer)
        df = table(run) if run is not None and run.status == "ok" else None
        if df is None or df.empty:
            continue
        df = df.copy()
        df.insert(0, "method", display_name(exp))
        df.insert(0, "experiment", exp)
        parts.append(df)
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame()


#: The columns of the metrics this project adds (mcd.core.metrics.ADDED_METRICS; docs/benchmark.md "Metrics"),
#: the same in every table: ``(column, metrics.json key, scale)``.
ADDED_COLUMNS = (
    ("FLIP", "flip", 1e2),
    ("tPSNR", "tpsnr", 1.0),
    ("border gap", "border_gap", 1.0),
    ("input border gap", "input_border_gap", 1.0),
    ("colour shift %", "colour_shift", 1e2),
    ("edge effect", "edge_effect", 1.0),
)
ADDED_NOTE = ("FLIP x1e2 (LDR-FLIP of the display images, lower is better), tPSNR in dB (PSNR of frame "
              "differences), border gap in dB (PSNR of the outer 4-pixel frame minus the interior's; the "
              "input's beside it shows the content's share), colour shift % (largest per-channel difference "
              "of the frame mean from the reference's), edge effect in dB (PSNR of a crop's outer 4-pixel "
              "frame minus that of the same pixels denoised inside the whole frame: what the image border "
              "itself costs; tools/edge_effect.py): metrics this project adds (docs/benchmark.md "
              "\"Metrics\"); empty for runs from before them.")


def added_columns(run: Run | None) -> dict[str, float]:
    """The :data:`ADDED_COLUMNS` of a run (NaN where it has no such metric)."""
    return {col: metric(run, key, scale) for col, key, scale in ADDED_COLUMNS}


def _status(run: Run | None) -> str:
    if run is None:
        return "not run"
    return run.status if run.status == "ok" else f"{run.status}: {run.error_message}"


def table1_experiments(ran: set[str]) -> list[str]:
    """Table 1's experiments in order: :data:`TABLE1_ROWS`, each followed by its variants in ``ran``."""
    return [e for row in TABLE1_ROWS
            for e in (row, *(v for v, of in TABLE1_VARIANTS.items() if of == row and v in ran))]


def table1(runs: list[Run], root: Path | None = None) -> pd.DataFrame:
    """PSNR, SSIM x1e2, rMSE x1e3 (the paper's Table 1 has none), GMACs, M params at 4 spp per method, our
    value beside the paper's; PSNR also over the training scenes' test frames alone (``PSNR train scenes``:
    the paper's Table 1 protocol; the mean over all test scenes includes the held-out ones).

    A method with a ``stand_in`` (the U-Net is row A's network, docs/baselines.md) that has no finished job
    gets that experiment's run, and says so.
    """
    rows = []
    for exp in table1_experiments({r.experiment for r in runs}):
        run = pick(runs, exp, TABLE1_BUDGET, prefer_sweep="baselines")
        source = exp
        other = BY_EXPERIMENT[exp].stand_in if exp in BY_EXPERIMENT else None
        if other is not None and (run is None or run.status != "ok"):
            alt = pick(runs, other, TABLE1_BUDGET, prefer_sweep="ablation")
            if alt is not None and alt.status == "ok":
                run, source = alt, other
        ref = paper.table1(TABLE1_VARIANTS.get(exp, exp))
        rows.append(
            {
                "method": display_name(exp) + (" (row A)" if source == "A" else ""),
                "experiment": source,
                "PSNR": metric(run, "psnr"),
                "PSNR paper": ref["psnr"],
                "PSNR train scenes": train_scene_metric(run),
                "SSIM": metric(run, "ssim", 1e2),
                "SSIM paper": ref["ssim"],
                "rMSE": metric(run, "rmse", 1e3),
                "GMACs": metric(run, "macs_g"),
                "GMACs paper": ref["macs_g"],
                "Params M": metric(run, "params_m"),
                "Params M paper": ref["params_m"],
                **added_columns(run),
                "input PSNR": metric(run, "input_psnr"),
                "status": _status(run),
                "run": run_label(run, root),
            }
        )
    return pd.DataFrame(rows)


def components(runs: list[Run], root: Path | None = None) -> pd.DataFrame:
    """Rows A-M: switches as ticks, PSNR (and over the training scenes alone), SSIM x1e2, L_t x1e2, rMSE x1e3,
    GMACs, params; paper beside; the kernel map's identity share for the KP rows (1 = the pool unused,
    ``i_bar == i``)."""
    rows = []
    for exp in COMPONENT_ROWS:
        run = pick(runs, exp, TABLE1_BUDGET, prefer_sweep="ablation")
        # the switches the job ran with; for rows that did not run, the row's definition (docs/method.md)
        switches = run.method_switches if run is not None and run.method_switches else paper.switches(exp)
        ref = paper.components(exp)
        row: dict[str, object] = {"row": exp}
        row.update({s: ("✓" if switches.get(s) else "") for s in SWITCHES})
        for col, key, scale, pkey in (
            ("PSNR", "psnr", 1.0, "psnr"),
            ("SSIM", "ssim", 1e2, "ssim"),
            ("L_t", "lt", 1e2, "lt"),
            ("rMSE", "rmse", 1e3, "rmse"),
            ("GMACs", "macs_g", 1.0, "macs_g"),
            ("Params M", "params_m", 1.0, "params_m"),
        ):
            row[col] = metric(run, key, scale)
            row[f"{col} paper"] = ref[pkey]
            if key == "psnr":
                row["PSNR train scenes"] = train_scene_metric(run)
        row.update(added_columns(run))
        row["KP identity"] = metric(run, "kp_identity")
        row["KP index std"] = metric(run, "kp_index_std")
        row["map ring ratio"] = metric(run, "map_border_ratio")
        row["KP index ring"] = metric(run, "index_border")
        row["status"] = _status(run)
        row["run"] = run_label(run, root)
        rows.append(row)
    return pd.DataFrame(rows)


def _steps(psnr: dict[str, float]) -> dict[str, float]:
    return {f"{a}→{b}": psnr[b] - psnr[a] for a, b in zip(STEPS, STEPS[1:], strict=False)}


def _range(kind: str, df: pd.DataFrame, col: str) -> list[Finding]:
    """The lowest and highest ``col`` over the rows that have it: one finding naming both rows (one row,
    named once, when only one has it or both ends are the same row)."""
    if col not in df:
        return []
    values = {str(r["row"]): float(r[col]) for _, r in df.iterrows() if not math.isnan(float(r[col]))}
    if not values:
        return []
    lo, hi = min(values, key=values.get), max(values, key=values.get)
    rows = (lo,) if lo == hi or values[lo] == values[hi] else (lo, hi)
    return [Finding(kind, "measured", col, "", rows, {r: values[r] for r in rows}, TABLE1_BUDGET)]


def component_checks(df: pd.DataFrame) -> list[Finding]:
    """The paper's two claims about the component study, checked against our numbers and the paper's:

    - F above A (the full method beats the plain denoiser);
    - C's gain over B (the kernel pool) is the largest single step along A→B→C→D→E→F;

    and, from our runs, the range of the kernel map's identity share and of its index spread over the rows
    with a kernel pool (:mod:`mcd.reporting.finding` renders them)."""
    found = []
    for source, col in (("ours", "PSNR"), ("paper", "PSNR paper")):
        psnr = {r["row"]: float(r[col]) for _, r in df.iterrows()}
        missing = [x for x in STEPS if math.isnan(psnr.get(x, math.nan))]
        if missing:
            found.append(Finding("component_rows_missing", "cannot check", "psnr", "dB", (), {},
                                 TABLE1_BUDGET, source=source, detail={"missing": missing}))
            continue
        found.append(Finding("f_above_a", "holds" if psnr["F"] > psnr["A"] else "does not hold", "psnr", "dB",
                             ("F", "A"), {"F": psnr["F"], "A": psnr["A"]}, TABLE1_BUDGET, source=source,
                             detail={"claim": "F above A"}))
        steps = _steps(psnr)
        largest = max(steps, key=steps.get)
        verdict = "holds" if largest == "B→C" else "does not hold"
        found.append(Finding("kp_largest_step", verdict, "psnr", "dB", STEPS, {x: psnr[x] for x in STEPS},
                             TABLE1_BUDGET, source=source,
                             detail={"claim": "C's gain over B is the largest single step", "steps": steps}))
    found += _range("kp_identity_share", df, "KP identity")
    found += _range("kp_index_spread", df, "KP index std")
    return found


#: Methods without training shown beside the transfer jobs, from their 4-spp job's scores on the same scene.
TRANSFER_REFERENCES = ("oidn",)


def _scene_row(run: Run, scene: str, root: Path | None) -> dict[str, object] | None:
    """A transfer-table row of a method that needs no training (OIDN) on ``scene``, from its run's
    per-scene scores (the transfer jobs' test frames are the same scene's test frames)."""
    scores = (run.metrics or {}).get("per_scene", {}).get(scene)
    if not scores:
        return None

    def get(key: str, scale: float = 1.0) -> float:
        value = scores.get(key)
        return math.nan if value is None else float(value) * scale

    return {"method": display_name(run.experiment), "scene": scene, "fine-tuned": False,
            "fine-tune epochs": 0, "PSNR": get("psnr"), "SSIM": get("ssim", 1e2), "rMSE": get("rmse", 1e3),
            "L_t": get("lt", 1e2), **{col: get(key, scale) for col, key, scale in ADDED_COLUMNS},
            "input PSNR": get("input_psnr"), "input FLIP": get("input_flip", 1e2),
            "run": run_label(run, root) + " (its scores on this scene; no training)"}


def transfer(runs: list[Run], root: Path | None = None) -> pd.DataFrame:
    """Transfer jobs (metrics.json `transfer`): held-out scene, with and without fine-tuning; beside them
    the methods of :data:`TRANSFER_REFERENCES` (no training) on the same scenes."""
    rows = []
    for run in runs:
        t = run.transfer
        if t is None:
            continue
        rows.append(
            {
                "method": display_name(run.experiment),
                "scene": t.get("scene", "?"),
                "fine-tuned": bool(t.get("finetune", False)),
                "fine-tune epochs": t.get("finetune_epochs", 0),
                "PSNR": metric(run, "psnr"),
                "SSIM": metric(run, "ssim", 1e2),
                "rMSE": metric(run, "rmse", 1e3),
                "L_t": metric(run, "lt", 1e2),
                **added_columns(run),
                "input PSNR": metric(run, "input_psnr"),
                "input FLIP": metric(run, "input_flip", 1e2),
                "run": run_label(run, root),
            }
        )
    for scene in dict.fromkeys(str(r["scene"]) for r in rows):
        for exp in TRANSFER_REFERENCES:
            ref = pick(runs, exp, TABLE1_BUDGET, prefer_sweep="baselines")
            row = _scene_row(ref, scene, root) if ref is not None and ref.status == "ok" else None
            if row is not None:
                rows.append(row)
    return pd.DataFrame(rows)


def write_all(runs: list[Run], out_dir: Path, root: Path | None = None) -> dict[str, pd.DataFrame]:
    """Write table1, components (and transfer when there are transfer jobs); return the frames."""
    t1 = table1(runs, root)
    scale_note = (
        "SSIM x1e2, rMSE x1e3 (relative MSE, lower is better; not in the paper's Table 1), GMACs per "
        "1920x1080 frame, params in millions; `paper` columns: the paper's Table 1."
    )
    write_table(
        t1,
        out_dir,
        "table1",
        "Table 1: methods at 4 spp",
        [
            scale_note,
            "Our PSNR/SSIM come from our data (see README: profile, scenes); compare orderings and "
            "MACs/params, "
            "not absolute PSNR, with the paper.",
            f"{display_name('oidn')} and the noisy input are references the paper does not list.",
            ADDED_NOTE,
        ],
    )
    comp = components(runs, root)
    write_table(
        comp,
        out_dir,
        "components",
        "Component study (A-M) at 4 spp",
        [
            "SSIM x1e2, L_t x1e2, rMSE x1e3, GMACs per 1920x1080 frame, params in millions; "
            "`paper` columns: the paper's component table.",
            ADDED_NOTE,
            "map ring ratio: the sampling map's mean on the outermost pixel ring over its interior mean (1: "
            "no preference for the border); KP index ring: the kernel index h[0] on that ring (the "
            "interior's spread is KP index std); both measured with the edge effect (python -m "
            "tools.edge_effect).",
            *map(render, component_checks(comp)),
        ],
    )
    frames = {"table1": t1, "components": comp}
    tr = transfer(runs, root)
    if not tr.empty:
        write_table(
            tr,
            out_dir,
            "transfer",
            "Transfer to held-out scenes",
            [
                "SSIM x1e2, rMSE x1e3, L_t x1e2. Models trained on the training scenes; `fine-tuned` runs "
                "were "
                "fine-tuned briefly on one clip of the held-out scene before testing on its test frames.",
                ADDED_NOTE,
            ],
        )
        frames["transfer"] = tr
    return frames

"""Choosing which run stands for an experiment in a table or figure, and writing tables as markdown + CSV."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd

from mcd.reporting.markdown_text import escape
from mcd.reporting.runs import Run


def pick(runs: list[Run], experiment: str, budget: float | None, prefer_sweep: str) -> Run | None:
    """The run of `experiment` at `budget` (any budget if None), excluding transfer jobs.

    Finished runs first; among them the default seed's (0: the seeds sweep trains the same config from other
    seeds, summarised apart in seeds.md), then the preferred sweep's, then any other sweep's (the same
    experiment at 4 spp is a job of several sweeps: ablation, baselines, spp). Without a finished run, the
    failed or incomplete one, so that tables show the failure instead of a silent gap.
    """
    cands = [
        r
        for r in runs
        if r.experiment == experiment and r.transfer is None and (budget is None or r.budget == budget)
    ]
    if not cands:
        return None

    def rank(r: Run) -> tuple[bool, bool, bool, str]:
        return (r.status != "ok", r.seed not in (0, None), r.sweep != prefer_sweep, str(r.path))

    return sorted(cands, key=rank)[0]


def metric(run: Run | None, key: str, scale: float = 1.0) -> float:
    """`metrics[key] * scale` of a finished run, NaN when the run or the value is missing."""
    if run is None or run.metrics is None:
        return math.nan
    value = run.metrics.get(key)
    try:
        return float(value) * scale
    except (TypeError, ValueError):
        return math.nan


def train_scenes(run: Run) -> list[str]:
    """The training scenes of the run's data profile (``data.train_scenes``)."""
    data = run.config.get("data") or {}
    return [str(s) for s in data.get("train_scenes") or []]


def scene_mean(run: Run | None, scenes: list[str], key: str = "psnr", scale: float = 1.0) -> float:
    """The mean of ``metrics["per_scene"][s][key] * scale`` over ``scenes``; NaN unless every one has it."""
    if run is None or run.metrics is None or not scenes:
        return math.nan
    per = run.metrics.get("per_scene") or {}
    values = [per[s].get(key) for s in scenes if s in per and per[s].get(key) is not None]
    return float(sum(values) / len(values)) * scale if len(values) == len(scenes) else math.nan


def train_scene_metric(run: Run | None, key: str = "psnr", scale: float = 1.0) -> float:
    """:func:`scene_mean` over the run's training scenes: the paper's Table 1 protocol (test frames of the
    scenes it trained on; held-out scenes are the transfer test's, docs/benchmark.md "Reports")."""
    return math.nan if run is None else scene_mean(run, train_scenes(run), key, scale)


def run_label(run: Run | None, root: Path | None = None) -> str:
    """Where a table row came from: the run directory (relative to `root` when possible) or `not run`."""
    if run is None:
        return "not run"
    if root is not None:
        try:
            return str(run.path.relative_to(root))
        except ValueError:
            pass
    return str(run.path)


#: From this magnitude on a table cell is written in scientific notation (an HDR rMSE x1e3 of 1e6 as
#: ``1e+09``), so that no cell grows to hundreds of digits.
SCIENTIFIC_FROM = 1e9


def _cell(value: object, digits: int) -> str:
    if isinstance(value, float):
        if math.isnan(value):
            return "—"
        return f"{value:.{digits}f}" if abs(value) < SCIENTIFIC_FROM else f"{value:.3g}"
    return escape(value)


def to_markdown(df: pd.DataFrame, digits: int = 2) -> str:
    """A GitHub-markdown table of `df` (floats to `digits` decimals, NaN as an em dash, text escaped by
    :func:`mcd.reporting.markdown_text.escape`)."""
    header = "| " + " | ".join(escape(c) for c in df.columns) + " |"
    rule = "|" + "|".join("---" for _ in df.columns) + "|"
    rows = ["| " + " | ".join(_cell(v, digits) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join([header, rule, *rows]) + "\n"


def write_table(
    df: pd.DataFrame, out_dir: Path, name: str, title: str, notes: list[str], digits: int = 2
) -> None:
    """`<name>.csv` (full precision) and `<name>.md` (title, table, notes) in `out_dir`."""
    df.to_csv(out_dir / f"{name}.csv", index=False)
    lines = [f"# {title}", "", to_markdown(df, digits)]
    lines += [f"- {n}" for n in notes]
    (out_dir / f"{name}.md").write_text("\n".join(lines) + "\n")

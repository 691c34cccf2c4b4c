"""The scaling study's runs at their scale points (docs/benchmark.md "Scaling report").

A *scale point* is a data profile and an optimiser-step budget (``data``, ``train.max_steps``); a *cell* is a
scale point and an experiment; a cell's runs are its seeds. :func:`read` takes every finished run at the
study's 4 spp (transfer jobs and other budgets are left out, each named with why), one run per cell and seed;
:func:`cells` gives each cell's mean, standard error, range and the band the figure draws:

- mean ± standard error (sample standard deviation over ``sqrt(n)``) from :data:`SE_BAND_MIN_SEEDS` seeds;
- the seeds' range (min to max) with fewer, two seeds;
- none with one seed.

The scores are each run's ``metrics.json`` means over its test frames (``psnr`` and ``flip``, every test
scene; ``psnr_train`` over the training scenes' test frames, the paper's protocol). Each data profile has its
own test scenes, so scores compare along the steps of one profile, not across profiles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from mcd.config.methods import BY_EXPERIMENT, display_name
from mcd.reporting.runs import Run
from mcd.reporting.select import metric, train_scene_metric, train_scenes
from mcd.reporting.tables import TABLE1_BUDGET

#: The sweep whose runs make a report a scaling report by themselves (``sweep_name`` of
#: ``conf/sweep/scaling.yaml``).
SWEEP = "scaling"
#: The study's methods, in the legend's order (``conf/sweep/scaling.yaml``); diagnostics and other
#: experiments follow.
STUDY = ("F", "F_paper", "C", "A", "ntasad")
#: The scores of a cell: ``metrics.json`` keys, and ``psnr_train``
#: (:func:`mcd.reporting.select.train_scene_metric`).
SCORES = ("psnr", "flip", "psnr_train")
#: From this many seeds a cell's band is mean ± standard error; with fewer (two) it is the seeds' range.
SE_BAND_MIN_SEEDS = 3


def is_scaling(runs: list[Run]) -> bool:
    """Whether a report of ``runs`` is a scaling report by itself: some run is a job of the scaling sweep."""
    return any(r.sweep == SWEEP for r in runs)


def steps_of(run: Run) -> int | None:
    """A run's optimiser-step budget: its config's ``train.max_steps``, else (a budget of epochs or minutes)
    the steps it trained (``metrics.json`` ``train_steps``); None when neither is recorded."""
    value = (run.config.get("train") or {}).get("max_steps")
    if value is None and run.metrics is not None:
        value = run.metrics.get("train_steps")
    try:
        return None if value is None else int(value)
    except (TypeError, ValueError):
        return None


def order(experiments: list[str] | set[str]) -> list[str]:
    """Experiments in the legend's order: :data:`STUDY`, then the diagnostics, then the rest by name."""
    def rank(exp: str) -> tuple[int, int, str]:
        if exp in STUDY:
            return 0, STUDY.index(exp), exp
        entry = BY_EXPERIMENT.get(exp)
        return (1 if entry is not None and entry.diagnostic else 2), 0, exp

    return sorted(set(experiments), key=rank)


@dataclass
class Grid:
    """The runs at their scale points: ``points`` has one row per run (columns ``data``, ``train_scenes``,
    ``steps``, ``experiment``, ``method``, ``seed``, the :data:`SCORES`, ``ssim``, ``train_steps``,
    ``stop_reason``, ``path``); ``left_out`` says which finished runs are not in it, and why."""

    points: pd.DataFrame
    left_out: list[str] = field(default_factory=list)

    @property
    def data(self) -> list[str]:
        """The data profiles with runs, smallest first (by training scenes, then name)."""
        if self.points.empty:
            return []
        sizes = self.points.groupby("data")["train_scenes"].max()
        return sorted(sizes.index, key=lambda d: (sizes[d], d))

    def train_scene_count(self, data: str) -> int:
        """How many training scenes the runs of ``data`` had (the most any run of it recorded)."""
        return int(self.points.loc[self.points["data"] == data, "train_scenes"].max())

    def viewer_point(self) -> tuple[str, int] | None:
        """The largest scale point the methods share, the one the viewer shows: the largest data profile
        present, at the largest of its budgets where the most methods ran (a budget only one method has
        reached yet would show that method alone)."""
        if not self.data:
            return None
        data = self.data[-1]
        methods = self.points[self.points["data"] == data].groupby("steps")["experiment"].nunique()
        return data, int(max(methods.index, key=lambda steps: (methods[steps], steps)))

    def runs_at(self, runs: list[Run], data: str, steps: int) -> list[Run]:
        """The runs of ``runs`` at one scale point."""
        paths = set(self.points.loc[(self.points["data"] == data) & (self.points["steps"] == steps), "path"])
        return [r for r in runs if str(r.path) in paths]


def read(runs: list[Run]) -> Grid:
    """Every finished run at 4 spp at its scale point (module docstring). Of two runs of one cell and seed
    (runs of one job that differ in other overrides) the first by path is kept, the other left out; so is a
    run without a PSNR, and one whose data settings or capacity profile differ from its data profile's first
    run's (it would be averaged and compared with another recipe's runs)."""
    rows, left_out, seen, firsts = [], [], {}, {}
    for r in sorted((r for r in runs if r.status == "ok"), key=lambda r: str(r.path)):
        steps = steps_of(r)
        why = ("a transfer job" if r.transfer is not None else
               f"{r.budget:g} spp, the study is at {TABLE1_BUDGET:g}" if r.budget != TABLE1_BUDGET else
               "no step budget recorded (train.max_steps, train_steps)" if steps is None else
               "no PSNR (metrics.json `psnr` is null: a NaN score), so its seed would count without a value"
               if math.isnan(metric(r, "psnr")) else None)
        key = (r.data_profile, steps, r.experiment, r.seed or 0)
        if why is None and key in seen:
            why = f"the same data, steps, experiment and seed as {seen[key]}; the first by path is kept"
        if why is None:  # a profile's runs are one recipe: the data and capacity of its first run
            why = _other_recipe(r, firsts.setdefault(r.data_profile, r))
        if why is not None:
            left_out.append(f"`{r.path}`: {why}")
            continue
        seen[key] = r.path.name
        rows.append({"data": r.data_profile, "train_scenes": len(train_scenes(r)), "steps": steps,
                     "experiment": r.experiment, "method": display_name(r.experiment), "seed": r.seed or 0,
                     "psnr": metric(r, "psnr"), "flip": metric(r, "flip"),
                     "psnr_train": train_scene_metric(r),
                     "ssim": metric(r, "ssim"), "train_steps": r.metrics.get("train_steps"),
                     "stop_reason": r.metrics.get("stop_reason"), "code": r.code, "path": str(r.path)})
    columns = ["data", "train_scenes", "steps", "experiment", "method", "seed", *SCORES, "ssim",
               "train_steps", "stop_reason", "code", "path"]
    return Grid(pd.DataFrame(rows, columns=columns), left_out)


def _other_recipe(run: Run, first: Run) -> str | None:
    """Why ``run`` does not belong beside ``first``, the first run of its data profile: another capacity
    profile, or other data settings (``metrics.json`` ``data_settings``: frame size, samples, scenes, ...;
    compared where both records have them); None when it belongs."""
    keys = [k for k in ("data_settings", "capacity_profile")
            if run.metrics.get(k) is not None and first.metrics.get(k) is not None
            and run.metrics[k] != first.metrics[k]]
    return (None if not keys else
            f"other {' and '.join(keys)} (metrics.json) than `{first.path}`, the first run of data profile "
            f"{first.data_profile}: the seeds, steps and methods compared on one profile must share its data "
            "and capacity")


def _se(values: pd.Series) -> float:
    """Standard error of the mean: sample standard deviation (n-1) over sqrt(n); NaN below two values."""
    return float(values.std(ddof=1) / math.sqrt(len(values))) if len(values) > 1 else math.nan


def band_rule(n: int) -> str:
    """Which band a cell of ``n`` seeds gets (module docstring)."""
    return "mean ± se" if n >= SE_BAND_MIN_SEEDS else "range" if n == 2 else "none"


def cells(grid: Grid) -> pd.DataFrame:
    """One row per cell: ``data``, ``train_scenes``, ``steps``, ``experiment``, ``method``, ``n``, ``seeds``,
    for each score its ``mean``, ``se``, ``min``, ``max`` and the band's ``lo`` and ``hi``, ``band`` (the
    rule), and ``stopped early`` (runs that stopped before their budget, with the step and why)."""
    p = grid.points
    rows = []
    for (data, steps, exp), df in p.groupby(["data", "steps", "experiment"], sort=False):
        n, rule = len(df), band_rule(len(df))
        row: dict[str, object] = {"data": data, "train_scenes": int(df["train_scenes"].max()),
                                  "steps": int(steps), "experiment": exp, "method": display_name(str(exp)),
                                  "n": n,
                                  "seeds": ",".join(str(s) for s in sorted(df["seed"])), "band": rule}
        for score in SCORES:
            v = df[score].dropna()
            mean, lo, hi = (float(v.mean()), float(v.min()), float(v.max())) if len(v) else (math.nan,) * 3
            se = _se(v)
            row |= {f"{score} mean": mean, f"{score} se": se, f"{score} min": lo, f"{score} max": hi}
            row |= ({f"{score} lo": mean - se, f"{score} hi": mean + se} if rule == "mean ± se" else
                    {f"{score} lo": lo, f"{score} hi": hi} if rule == "range" else
                    {f"{score} lo": mean, f"{score} hi": mean})
        early = df[df["train_steps"].notna() & (df["train_steps"] < steps)]
        row["stopped early"] = "; ".join(f"seed {s} at step {int(t)} ({why})" for s, t, why in
                                         zip(early["seed"], early["train_steps"], early["stop_reason"],
                                             strict=True))
        row["code"] = code_of(df)
        rows.append(row)
    out = pd.DataFrame(rows)
    if out.empty:
        return out
    data_rank = {d: i for i, d in enumerate(grid.data)}
    exp_rank = {e: i for i, e in enumerate(order(set(out["experiment"])))}
    return out.sort_values(["data", "steps", "experiment"], key=lambda c: c.map(data_rank) if c.name == "data"
                           else c.map(exp_rank) if c.name == "experiment" else c).reset_index(drop=True)


def codes(runs: pd.DataFrame) -> tuple[str, ...]:
    """The code of a cell's runs (``Run.code``), each once, in seed order; ``("?",)`` where the points have no
    ``code`` (a grid built without it)."""
    if "code" not in runs:
        return ("?",)
    return tuple(dict.fromkeys(str(c) for c in runs.sort_values("seed")["code"]))


def code_of(runs: pd.DataFrame) -> str:
    """:func:`codes` as the tables show them, ``; ``-joined."""
    return "; ".join(codes(runs))


def codes_at(grid: Grid, data: str, steps: int, experiment: str) -> tuple[str, ...]:
    """:func:`codes` of one cell's runs (empty where it has none)."""
    p = grid.points
    df = p[(p["data"] == data) & (p["steps"] == steps) & (p["experiment"] == experiment)]
    return codes(df) if len(df) else ()


def by_seed(grid: Grid, data: str, steps: int, experiment: str, score: str = "psnr") -> dict[int, float]:
    """``{seed: score}`` of one cell's runs (empty when the cell has none)."""
    p = grid.points
    df = p[(p["data"] == data) & (p["steps"] == steps) & (p["experiment"] == experiment)]
    return {int(s): float(v) for s, v in zip(df["seed"], df[score], strict=True) if not pd.isna(v)}


def root_relative(path: str, root: Path) -> str:
    """``path`` relative to ``root`` where it lies under it."""
    p = Path(path)
    return str(p.relative_to(root)) if p.is_relative_to(root) else str(p)

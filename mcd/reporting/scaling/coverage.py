"""What the scaling grid covers: the sweep's plan against the runs present (docs/benchmark.md "Scaling
report").

The plan is the grid of ``conf/sweep/scaling.yaml`` (``hydra.sweeper.params``) less the jobs its seed rule
drops (``sweep_plan.seeds_only_where``, :func:`mcd.lit.sweep_plan.keep`): the jobs ``python -m mcd.run -m
+sweep=scaling`` would run without narrowing. Each planned job is ``finished`` (a run of its data, steps,
experiment and seed is in the grid), ``failed`` (its run directory holds ``error.json``), ``incomplete`` (a
run directory without either record: killed, or still running) or ``not run`` (no run directory). The study
runs over several sessions, so a report of a partial grid lists what is missing; finished runs outside the
plan (other budgets, other seeds) are reported too.
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd
from omegaconf import OmegaConf

from mcd.core.paths import CONF_DIR
from mcd.lit.sweep_plan import job_values, keep
from mcd.reporting.finding import Finding
from mcd.reporting.runs import Run
from mcd.reporting.scaling.grid import Grid, order, steps_of

#: The sweep file whose grid is the plan.
SWEEP_FILE = CONF_DIR / "sweep" / "scaling.yaml"
#: The plan's axes: the sweep's override keys and the columns they become.
AXES = {"data": "data", "train.max_steps": "steps", "experiment": "experiment", "seed": "seed"}
KEY = ["data", "steps", "experiment", "seed"]


def planned(sweep_file: Path = SWEEP_FILE) -> pd.DataFrame:
    """The plan's jobs (module docstring): columns ``data``, ``steps``, ``experiment``, ``seed``."""
    import itertools

    cfg = OmegaConf.load(sweep_file)
    params = {k.lstrip("+"): [v.strip() for v in str(values).split(",")]
              for k, values in cfg.hydra.sweeper.params.items()}
    unknown = set(params) - set(AXES)
    if unknown:
        raise ValueError(f"{sweep_file}: hydra.sweeper.params has {sorted(unknown)}, which the scaling "
                         f"report does not read as an axis (it reads {sorted(AXES)})")
    base = int(OmegaConf.load(CONF_DIR / "config.yaml").get("seed", 0))  # the sweeper's base seed
    only = cfg.sweep_plan.get("seeds_only_where")
    only = OmegaConf.to_container(only) if only is not None else None
    rows = []
    for values in itertools.product(*params.values()):
        job = dict(zip(params, values, strict=True))
        if keep(job_values(f"{k}={v}" for k, v in job.items()), base, only):  # type: ignore[arg-type]
            rows.append({AXES[k]: v for k, v in job.items()})
    df = pd.DataFrame(rows, columns=KEY)
    return df.astype({"steps": int, "seed": int})


def _status(runs: list[Run]) -> dict[tuple, str]:
    """``{(data, steps, experiment, seed): status}`` of every run directory (a finished run wins)."""
    found: dict[tuple, str] = {}
    for r in runs:
        key = (r.data_profile, steps_of(r), r.experiment, r.seed or 0)
        if found.get(key) != "ok":
            found[key] = r.status
    return found


def jobs(runs: list[Run], grid: Grid, plan: pd.DataFrame) -> pd.DataFrame:
    """The plan's jobs with their ``status`` (module docstring) and ``run`` (the grid's run of a finished
    job), then the grid's runs outside the plan (``status`` ``outside the plan``)."""
    status = _status(runs)
    p = grid.points
    present = {(d, int(s), e, int(sd)): path for d, s, e, sd, path in
               zip(p["data"], p["steps"], p["experiment"], p["seed"], p["path"], strict=True)}
    words = {"ok": "finished", "failed": "failed", "incomplete": "incomplete"}
    rows = []
    for d, s, e, sd in plan[KEY].itertuples(index=False):
        key = (d, int(s), e, int(sd))
        state = "finished" if key in present else words.get(status.get(key, ""), "not run")
        rows.append({"data": d, "steps": int(s), "experiment": e, "seed": int(sd), "status": state,
                     "run": present.get(key, "")})
    in_plan = {tuple(r[k] for k in KEY) for r in rows}
    rows += [{"data": k[0], "steps": k[1], "experiment": k[2], "seed": k[3], "status": "outside the plan",
              "run": path} for k, path in present.items() if k not in in_plan]
    return pd.DataFrame(rows, columns=[*KEY, "status", "run"])


def missing(table: pd.DataFrame) -> list[dict[str, object]]:
    """The planned jobs not finished, one entry per data, steps and experiment: its ``seeds`` and their
    ``status`` (each distinct status, joined), in the plan's order."""
    todo = table[~table["status"].isin(("finished", "outside the plan"))]
    out = []
    for (d, s, e), df in todo.groupby(["data", "steps", "experiment"], sort=False):
        out.append({"data": d, "steps": int(s), "experiment": e, "seeds": [int(x) for x in df["seed"]],
                    "status": ", ".join(dict.fromkeys(df["status"]))})
    return out


def finding(table: pd.DataFrame, sweep_file: Path = SWEEP_FILE) -> Finding:
    """The ``scaling_coverage`` finding: how many planned jobs are in each state, which cells have runs,
    which planned jobs are missing (:func:`missing`) and how many runs lie outside the plan."""
    planned_rows = table[table["status"] != "outside the plan"]
    counts = planned_rows["status"].value_counts()
    done = table[table["status"].isin(("finished", "outside the plan"))]
    cells = [{"data": d, "steps": int(s), "experiments": order(set(df["experiment"]))}
             for (d, s), df in done.groupby(["data", "steps"], sort=False)]
    values = {"planned": float(len(planned_rows)),
              **{k: float(counts.get(k, 0)) for k in ("finished", "failed", "incomplete", "not run")},
              "outside the plan": float((table["status"] == "outside the plan").sum())}
    try:
        where = str(sweep_file.relative_to(CONF_DIR.parent))
    except ValueError:
        where = str(sweep_file)
    return Finding("scaling_coverage", "measured", "jobs", "", (), values,
                   detail={"sweep_file": where, "cells": cells, "missing": missing(table)})

"""The scaling sweep (``+sweep=scaling``, conf/sweep/scaling.yaml) and its planned sweeper
(mcd/lit/sweep_plan.py): the grid it runs, the plan it prints before any job, and the refusal of a grid above
its CPU-hour limit without ``sweep_plan.allow_large=true``, through the real ``python -m mcd.run -m``."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from mcd.core.paths import CONF_DIR
from mcd.lit.sweep_plan import STEP_KEYS, job_values, keep, plan_lines, plan_rows
from tests.conftest import command_in_worker

SWEEP = OmegaConf.load(CONF_DIR / "sweep" / "scaling.yaml")


def grid() -> list[list[str]]:
    """The sweep's jobs as the basic sweeper makes them, less those the seed rule drops."""
    import itertools

    params = SWEEP.hydra.sweeper.params
    lists = [[f"{k}={v}" for v in str(values).split(",")] for k, values in params.items()]
    only = OmegaConf.to_container(SWEEP.sweep_plan.seeds_only_where)
    return [list(j) for j in itertools.product(*lists) if keep(job_values(j), 0, only)]


def test_the_grid_is_the_studys():
    jobs = [job_values(j) for j in grid()]
    assert {j["experiment"] for j in jobs} == {"F", "F_paper", "C", "A", "ntasad"}
    assert {j["data"] for j in jobs} == {"tiny", "small", "medium"}
    assert {j["train.max_steps"] for j in jobs} == {"1000", "3000", "10000"}
    seeds = {(j["data"], j["train.max_steps"]): set() for j in jobs}
    for j in jobs:
        seeds[j["data"], j["train.max_steps"]].add(j["seed"])
    for cell, found in seeds.items():
        want = {"0", "1", "2"} if cell in (("small", "3000"), ("medium", "3000")) else {"0"}
        assert found == want, cell
    assert len(jobs) == 5 * (9 + 2 * 2)
    assert SWEEP.train.max_minutes is None and SWEEP.train.patience is None  # the steps are the budget


def test_the_plan_sums_each_cells_jobs():
    jobs = [["data=small", "train.max_steps=3000", "+experiment=F", f"seed={s}"] for s in (0, 1, 2)]
    jobs.append(["data=tiny", "train.max_steps=1000", "+experiment=F", "seed=0"])
    asked = []

    def config(job):
        v = job_values(job)
        crop = 96 if v["data"] == "small" else 64
        return OmegaConf.create({"data": {"name": v["data"], "train_crop": crop, "clip_len": 5},
                                 "train": {"max_steps": int(v["train.max_steps"]), "batch_size": 4},
                                 "experiment": v["experiment"], "seed": int(v["seed"]), "capacity": {}})

    def seconds(cfg):
        asked.append(cfg.data.name)
        return 2.0 if cfg.data.name == "small" else 1.0

    rows = plan_rows(jobs, config, seconds)
    assert asked == ["small", "tiny"]  # one measurement per experiment and crop
    small, tiny = rows
    assert small["seeds"] == [0, 1, 2] and small["cpu_h"] == pytest.approx(3 * 3000 * 2.0 / 3600)
    assert tiny["cpu_h"] == pytest.approx(1000 / 3600)
    assert plan_lines(rows, 40)[-1].startswith("plan: 4 jobs, 5.3 CPU-hours of training in all (limit 40")


def test_jobs_whose_step_differs_are_measured_apart():
    """Cells that share the method and the step's shape share one measurement; a cell whose configured
    precision (or any of :data:`STEP_KEYS`) differs gets its own."""
    jobs = [[f"data={d}", "train.max_steps=1000", "+experiment=F", "seed=0"]
            for d in ("small", "medium", "x")]

    def config(job):
        v = job_values(job)
        return OmegaConf.create({"data": {"name": v["data"], "train_crop": 96, "clip_len": 5},
                                 "train": {"max_steps": 1000, "batch_size": 4, "channels_last": True},
                                 "trainer": {"precision": "32-true" if v["data"] == "x" else "auto"},
                                 "experiment": "F", "seed": 0, "capacity": {}})

    asked = []
    rows = plan_rows(jobs, config, lambda cfg: asked.append(cfg.data.name) or 1.0)
    assert asked == ["small", "x"] and len(rows) == 3
    assert "trainer.precision" in STEP_KEYS and "train.channels_last" in STEP_KEYS


def mcd_run(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    """The sweep in the worker (:func:`tests.conftest.command_in_worker`)."""
    cmd = ["-m", "+sweep=scaling", "data=tiny", "train.max_steps=1000,3000", "+experiment=A",
           f"paths.data_dir={tmp_path / 'data'}", f"hydra.sweep.dir={tmp_path / 'sweep'}"]
    return command_in_worker("mcd.run", [*cmd, *args], tmp_path, {"OMP_NUM_THREADS": "1"})


@pytest.mark.slow
def test_the_plan_is_printed_and_a_large_grid_refused_before_any_job(tmp_path):
    """Row A on tiny at 1000 and 3000 steps: the plan (a measured step), a refusal under a limit below it
    that writes nothing, and a dry run under ``allow_large`` that prints the plan and runs nothing."""
    res = mcd_run(tmp_path, "sweep_plan.cpu_hours_limit=0.001")
    out = res.stdout + res.stderr
    assert res.returncode != 0
    rows = re.findall(r"tiny\s+(\d+) A\s+0\s+([\d.]+)\s+([\d.]+)", out)
    assert [int(r[0]) for r in rows] == [1000, 3000]
    step_s = float(rows[0][1])
    assert step_s > 0 and float(rows[1][1]) == step_s
    total = re.search(r"plan: 2 jobs, ([\d.]+) CPU-hours of training in all \(limit 0.001", out)
    assert total and float(total.group(1)) == pytest.approx(4000 * step_s / 3600, abs=0.06)
    assert "above sweep_plan.cpu_hours_limit=0.001" in out and "sweep_plan.allow_large=true" in out
    assert not (tmp_path / "sweep").exists() and not (tmp_path / "data").exists()
    res = mcd_run(tmp_path, "sweep_plan.cpu_hours_limit=0.001", "sweep_plan.allow_large=true",
                  "sweep_plan.dry_run=true")
    assert res.returncode == 0, res.stderr[-3000:]
    assert "plan: 2 jobs" in res.stdout + res.stderr
    assert not list((tmp_path / "sweep").glob("tiny/*")) and not (tmp_path / "data").exists()

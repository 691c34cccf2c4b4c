"""A dry run of the planned sweeper writes nothing (``mcd.lit.sweep_plan.PlannedSweeper.sweep``;
docs/reliability.md, "Campaign fixes"): Hydra's sweep saved ``<sweep dir>/multirun.yaml`` before the plan, so
a ``sweep_plan.dry_run=true`` into a finished sweep's folder replaced its record with the command of a sweep
that ran no job."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tests.conftest import REPO


@pytest.mark.slow
def test_a_dry_run_prints_the_plan_and_leaves_the_sweeps_record(tmp_path):
    sweep = tmp_path / "sweep"
    sweep.mkdir()
    record = sweep / "multirun.yaml"
    # an earlier sweep's record, as Hydra writes it (its mode, its overrides)
    record.write_text("hydra:\n  mode: MULTIRUN\n  overrides:\n    task: [data=tiny, +experiment=A]\n")
    before = record.read_bytes()
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO)}
    cmd = [sys.executable, "-m", "mcd.run", "-m", "+sweep=scaling", "data=tiny", "train.max_steps=1000",
           "+experiment=A", "sweep_plan.dry_run=true", f"paths.data_dir={tmp_path / 'data'}",
           f"hydra.sweep.dir={sweep}"]
    proc = subprocess.run(cmd, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-3000:]
    assert "plan: 1 jobs" in out
    assert record.read_bytes() == before
    assert sorted(p.name for p in sweep.iterdir()) == ["multirun.yaml"]

    fresh = tmp_path / "fresh"
    proc = subprocess.run([*cmd[:-1], f"hydra.sweep.dir={fresh}"], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0 and not fresh.exists()

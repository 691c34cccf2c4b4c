"""A dry run of the planned sweeper writes nothing (``mcd.lit.sweep_plan.PlannedSweeper.sweep``;
docs/reliability.md, "Campaign fixes"): Hydra's sweep saved ``<sweep dir>/multirun.yaml`` before the plan, so
a ``sweep_plan.dry_run=true`` into a finished sweep's folder replaced its record with the command of a sweep
that ran no job."""

from __future__ import annotations

import pytest

from tests.conftest import command_in_worker


@pytest.mark.slow
def test_a_dry_run_prints_the_plan_and_leaves_the_sweeps_record(tmp_path):
    sweep = tmp_path / "sweep"
    sweep.mkdir()
    record = sweep / "multirun.yaml"
    # an earlier sweep's record, as Hydra writes it (its mode, its overrides)
    record.write_text("hydra:\n  mode: MULTIRUN\n  overrides:\n    task: [data=tiny, +experiment=A]\n")
    before = record.read_bytes()
    env = {"OMP_NUM_THREADS": "1"}
    cmd = ["-m", "+sweep=scaling", "data=tiny", "train.max_steps=1000", "+experiment=A",
           "sweep_plan.dry_run=true", f"paths.data_dir={tmp_path / 'data'}", f"hydra.sweep.dir={sweep}"]
    proc = command_in_worker("mcd.run", cmd, tmp_path, env)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-3000:]
    assert "plan: 1 jobs" in out
    assert record.read_bytes() == before
    assert sorted(p.name for p in sweep.iterdir()) == ["multirun.yaml"]

    fresh = tmp_path / "fresh"
    proc = command_in_worker("mcd.run", [*cmd[:-1], f"hydra.sweep.dir={fresh}"], tmp_path, env)
    assert proc.returncode == 0 and not fresh.exists()

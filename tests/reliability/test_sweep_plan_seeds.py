"""The planned sweeper says which jobs ``sweep_plan.seeds_only_where`` leaves out (docs/reliability.md,
"Campaign fixes"; mcd/lit/sweep_plan.py): ``+sweep=scaling data=tiny seed=0,1,2`` planned "1 jobs" and ran
seed 0 only, with no word about the seeds typed on the command line (the study's rule runs seeds 1-2 only at
3000 steps on small and medium). The plan now names the rule, how many jobs it leaves out, and how to run
them."""

from __future__ import annotations

import pytest

from tests.conftest import command_in_worker


@pytest.mark.slow
def test_the_plan_says_how_many_jobs_the_seed_rule_leaves_out(tmp_path):
    cmd = ["-m", "+sweep=scaling", "data=tiny", "train.max_steps=1000", "+experiment=A", "seed=0,1,2",
           "sweep_plan.dry_run=true", f"paths.data_dir={tmp_path / 'data'}",
           f"hydra.sweep.dir={tmp_path / 'sweep'}"]
    proc = command_in_worker("mcd.run", cmd, tmp_path, {"OMP_NUM_THREADS": "1"})
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out[-3000:]
    assert "leaves out 2 of the grid's 3 jobs" in out and "sweep_plan.seeds_only_where=null runs them" in out
    assert "plan: 1 jobs" in out
    assert not list((tmp_path / "sweep").glob("tiny/*")) and not (tmp_path / "data").exists()

"""A sweep's command in a report is one that ran its jobs (``mcd.reporting.runs.find_sweeps``,
docs/reliability.md, "Campaign fixes"): Hydra rewrites a sweep's ``multirun.yaml`` in every process, also a
rerun whose jobs were all finished and skipped, so a rerun with ``capacity=paper`` made the report of runs
trained with ``capacity=cpu`` name ``... capacity=paper`` as their sweep's command. A key or value that no job
ran with is now left out or replaced by the jobs' own."""

from __future__ import annotations

import pytest

from mcd.reporting.runs import find_sweeps
from tests.conftest import mcd_run, store32_overrides


@pytest.mark.slow
def test_a_skipped_rerun_with_other_overrides_does_not_become_the_sweeps_command(cbox_store, tmp_path):
    sweep = tmp_path / "multirun" / "sw"
    common = ["-m", "+experiment=A", *store32_overrides(cbox_store[1].data_dir), "train.max_steps=1",
              "train.sample_frames=[]", "trainer.enable_progress_bar=false", f"hydra.sweep.dir={sweep}",
              "hydra.sweep.subdir=s${seed}"]
    first = mcd_run(*common, "seed=0,1")
    assert first.returncode == 0, first.stderr[-4000:]
    rerun = mcd_run(*common, "seed=0,1", "capacity=paper", "train.lr=0.5")  # both jobs skipped, finished
    assert rerun.returncode == 0 and rerun.stderr.count("skip: ") + rerun.stdout.count("skip: ") == 2
    assert "capacity=paper" in (sweep / "multirun.yaml").read_text()  # Hydra's record of the last process
    [found] = find_sweeps([sweep])
    assert "capacity" not in found.command and "train.lr" not in found.command
    assert "seed=0,1" in found.command and "train.max_steps=1" in found.command

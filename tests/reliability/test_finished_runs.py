"""A rerun into a finished run never rewrites its records (mcd/lit/run_dir.py, ``mcd.run.main``): Hydra saved
a rerun's ``.hydra/*.yaml`` into the finished run before ``mcd.run`` skipped it (so ``mcd.report`` then read
the rerun's ``capacity=paper`` for a ``capacity=cpu`` run), and a rerun of another job, refused, still wrote
``error.json`` there. Every file of the finished run now keeps its bytes."""

from __future__ import annotations

import shutil

import pytest

from tests.conftest import mcd_run
from tests.reliability.denoise_helpers import snapshot


@pytest.fixture
def finished(unet_run, tmp_path):
    """A run directory of ``+experiment=unet capacity=cpu`` that ``mcd.run`` finished: this test's copy of the
    session's ``unet_run``."""
    shared, base = unet_run
    run = tmp_path / "run"
    shutil.copytree(shared, run, symlinks=True)
    return run, base


@pytest.mark.slow
def test_a_rerun_of_the_same_job_with_another_capacity_is_skipped_and_changes_no_byte(finished):
    run, base = finished
    before = snapshot(run)
    proc = mcd_run("+experiment=unet", "capacity=paper", *base, f"hydra.run.dir={run}")
    assert proc.returncode == 0 and "skip:" in proc.stdout + proc.stderr, proc.stderr[-4000:]
    after = snapshot(run)
    assert sorted(after) == sorted(before)
    assert [name for name in before if after[name] != before[name]] == []
    assert "capacity: paper" not in (run / ".hydra" / "hydra.yaml").read_text()


@pytest.mark.slow
def test_a_rerun_of_another_job_is_refused_and_writes_nothing_there(finished):
    run, base = finished
    before = snapshot(run)
    proc = mcd_run("+experiment=F", *base, f"hydra.run.dir={run}")
    refusal = "holds a finished run of another job (experiment: 'unet' there, 'F' here"
    assert proc.returncode != 0 and refusal in proc.stderr, proc.stderr[-4000:]
    after = snapshot(run)
    assert sorted(after) == sorted(before)  # no error.json
    assert [name for name in before if after[name] != before[name]] == []

"""Campaign 10, part 1 (docs/reliability.md, "Campaign fixes"): a run never writes through a symbolic link in
its directory.

``run.lock`` linked to a user's file (a run directory in a shared folder, or one assembled with links):
``mcd.run hydra.run.dir=<dir>`` ran, exit 0, and the user's file held "pid 6118 on vm, since ..." instead of
its text (the lock's owner line is written into it); ``logs/metrics.csv`` and the checkpoints are written the
same way. Now such a directory is refused before anything is written: a single run with one ``error:`` line
naming ``hydra.run.dir`` and the links, exit 2; a sweep's job before it takes the lock. The linked files keep
their bytes.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import module_env, store32_overrides


def _run(tmp_path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mcd.run", *args, "+experiment=noisy",
                           *store32_overrides(tmp_path / "data"), "trainer.enable_progress_bar=false"],
                          cwd=tmp_path, env=module_env(), capture_output=True, text=True, timeout=600)


def test_a_link_where_a_run_writes_is_refused_and_its_target_kept(tmp_path):
    thesis = tmp_path / "thesis.tex"
    thesis.write_text("chapter 3\n")
    run = tmp_path / "run"
    (run / "logs").mkdir(parents=True)
    (run / "run.lock").symlink_to(thesis)
    (run / "logs" / "metrics.csv").symlink_to(thesis)
    proc = _run(tmp_path, f"hydra.run.dir={run}")
    assert proc.returncode == 2, (proc.stdout + proc.stderr)[-3000:]
    links = f"{run / 'logs' / 'metrics.csv'} -> {thesis}, {run / 'run.lock'} -> {thesis}"
    assert f"error: hydra.run.dir={run} holds symbolic links where a run writes ({links})" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert thesis.read_text() == "chapter 3\n" and not (tmp_path / "data").exists()
    assert sorted(p.name for p in run.iterdir()) == ["logs", "run.lock"]


@pytest.mark.slow
def test_a_sweep_job_with_a_linked_lock_is_refused_and_its_target_kept(tmp_path):
    thesis = tmp_path / "thesis.tex"
    thesis.write_text("chapter 3\n")
    job = tmp_path / "sweep" / "job"
    job.mkdir(parents=True)
    (job / "run.lock").symlink_to(thesis)
    proc = _run(tmp_path, "-m", f"hydra.sweep.dir={tmp_path / 'sweep'}", "hydra.sweep.subdir=job")
    assert proc.returncode != 0
    assert f"holds symbolic links where a run writes ({job / 'run.lock'} -> {thesis})" in proc.stderr
    assert thesis.read_text() == "chapter 3\n" and not (job / "metrics.json").exists()

"""Campaign 13 (docs/reliability.md, "Campaign fixes"): a sweep never replaces the record of another sweep
whose jobs lie in its ``hydra.sweep.dir``.

``python -m mcd.run -m ... seed=1 hydra.sweep.dir=<a finished seed=0 sweep>`` was refused at its job
("holds a finished run of another job"), yet Hydra had already replaced the finished sweep's
``multirun.yaml`` with its own, so the folder's record named ``seed=1`` beside the seed-0 run and
``mcd.report`` stated that command for it (high: a finished output's record rewritten by a refused command).
Now ``mcd.lit.sweep_dirs.check_sweep_record`` (the ``SweepDirs`` callback, before the sweeper writes) refuses
an earlier sweep's record whose overrides differ from this sweep's, naming each, exit 2, the record kept; the
same sweep run again (to finish it) goes on.
"""

from __future__ import annotations

import subprocess
import sys

from tests.conftest import module_env, store32_overrides


def _sweep(cwd, sweep_dir, seed: int) -> subprocess.CompletedProcess:
    argv = [sys.executable, "-m", "mcd.run", "-m", *store32_overrides(cwd / "data"), "+experiment=noisy",
            f"seed={seed}", "trainer.enable_progress_bar=false", f"hydra.sweep.dir={sweep_dir}"]
    return subprocess.run(argv, cwd=cwd, env=module_env(), capture_output=True, text=True, timeout=600)


def test_another_sweep_does_not_replace_a_finished_sweeps_record(tmp_path):
    sweep = tmp_path / "sweep"
    first = _sweep(tmp_path, sweep, 0)
    assert first.returncode == 0, (first.stdout + first.stderr)[-4000:]
    record = (sweep / "multirun.yaml").read_bytes()
    assert b"- seed=0" in record

    other = _sweep(tmp_path, sweep, 1)
    assert other.returncode == 2, (other.stdout + other.stderr)[-4000:]
    assert (f"error: hydra.sweep.dir={sweep} holds multirun.yaml, the record of another sweep "
            "(seed: 0 there, 1 here)") in other.stderr
    assert "Traceback" not in other.stderr
    assert (sweep / "multirun.yaml").read_bytes() == record  # the finished sweep's record kept

    again = _sweep(tmp_path, sweep, 0)  # the same sweep again: goes on (its job skipped as finished)
    assert again.returncode == 0, (again.stdout + again.stderr)[-4000:]
    assert "skip:" in again.stdout + again.stderr

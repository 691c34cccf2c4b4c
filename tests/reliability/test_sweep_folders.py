"""Campaign 11, part 1 (docs/reliability.md, "Campaign fixes"): a sweep's folders stay where its keys say, and
its refusals are one line.

- ``sweep_tag`` is a suffix of the named sweeps' folder (``multirun/<sweep>/<profile><sweep_tag>``,
  ``sweeps/_sweep_dirs.yaml``): ``sweep_tag=/../../../../x`` put five jobs outside ``multirun/`` and the
  working directory, exit 0 (campaign 10 left it); a ``hydra.sweep.subdir`` with ``..`` put a job outside
  ``hydra.sweep.dir``. Both are now one ``error:`` line naming the key, exit 2, nothing written.
- A ``+sweep=scaling`` plan above ``sweep_plan.cpu_hours_limit`` ended in the ValueError's traceback around
  its clear message (campaign 10 left it); now that message is one ``error:`` line, exit 2.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import command_in_worker, module_env, store32_overrides


def _mcd_run(cwd, *overrides: str, in_worker: bool = False) -> subprocess.CompletedProcess:
    """The sweep in its own process (a refusal before the heavy imports: under a second of CPU), or in the
    worker (:func:`tests.conftest.command_in_worker`) where it measures a training step first."""
    argv = ["-m", "mcd.run", "-m", *store32_overrides(cwd / "data"), "trainer.enable_progress_bar=false",
            *overrides]
    if in_worker:
        return command_in_worker(argv[1], argv[2:], cwd, module_env())
    return subprocess.run([sys.executable, *argv], cwd=cwd, env=module_env(), capture_output=True, text=True,
                          timeout=600)


@pytest.mark.parametrize("override, key", [("sweep_tag=/../../../../x", "sweep_tag='/../../../../x'"),
                                           ("hydra.sweep.subdir=../../x_${seed}",
                                            "hydra.sweep.subdir='../../x_0' (job 0)")])
def test_a_sweep_folder_outside_its_root_is_refused_naming_the_key(tmp_path, override, key):
    cwd = tmp_path / "a"
    cwd.mkdir()
    proc = _mcd_run(cwd, "+sweep=seeds", "+experiment=noisy", override)
    assert proc.returncode == 2, (proc.stdout + proc.stderr)[-4000:]
    assert f"error: {key}" in proc.stderr and "Traceback" not in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a"]  # nothing written beside the working dir
    assert not (cwd / "data").exists() and not (cwd / "multirun").exists()


@pytest.mark.slow
def test_a_plan_above_its_limit_is_one_error_line(tmp_path):
    proc = _mcd_run(tmp_path, "+sweep=scaling", "+experiment=A", "train.max_steps=1000",
                    "sweep_plan.cpu_hours_limit=0.000001", f"hydra.sweep.dir={tmp_path / 'sweep'}",
                    in_worker=True)
    assert proc.returncode == 2, (proc.stdout + proc.stderr)[-4000:]
    assert "error: the sweep's plan is" in proc.stderr and "sweep_plan.allow_large=true" in proc.stderr
    assert "Traceback" not in proc.stderr and not (tmp_path / "sweep").exists()

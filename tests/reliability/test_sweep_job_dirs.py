"""Campaign 10, part 1 (docs/reliability.md, "Campaign fixes"): a sweep is checked before its first job.

- Jobs that resolve to one directory: the named sweeps' job directories hold the experiment and the budget
  only (``sweeps/_sweep_dirs.yaml``), so ``+sweep=baselines +experiment=noisy train.lr=0.001,0.002`` ran job 0
  and skipped job 1 as "finished" (exit 0), and ``seed=0,1`` ended in a FileExistsError after job 0 (campaign
  9 left both). Now one ``error:`` line names the jobs, the overrides that tell them apart,
  ``hydra.sweep.subdir`` and ``sweep_tag``, exit 2, before anything is rendered or written; the advice,
  followed, runs both jobs.
- A read-only ``hydra.sweep.dir`` ended in an OSError traceback from Hydra's sweeper (campaign 8 left it); now
  one ``error:`` line names the key, exit 2, nothing made.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import command_in_worker, module_env, store32_overrides

NOISY = ["-m", "mcd.run", "-m", "+sweep=baselines", "+experiment=noisy", "trainer.enable_progress_bar=false"]


def _sweep(tmp_path, *overrides: str, wrap=None) -> subprocess.CompletedProcess:
    """The sweep in this process (:func:`tests.conftest.command_in_worker`); in its own process under `wrap`
    (the read-only mount)."""
    argv = [*NOISY, *store32_overrides(tmp_path / "data"), *overrides]
    if wrap is None:
        return command_in_worker(argv[1], argv[2:], tmp_path, module_env())
    return subprocess.run(wrap([sys.executable, *argv]), cwd=tmp_path, env=module_env(), capture_output=True,
                          text=True, timeout=600)


@pytest.mark.parametrize("grid, key, values", [("train.lr=0.001,0.002", "train.lr", "0.001 / 0.002"),
                                               ("seed=0,1", "seed", "0 / 1")])
def test_jobs_that_would_share_a_directory_are_refused_before_any_job_runs(tmp_path, grid, key, values):
    sweep = tmp_path / "sweep"
    proc = _sweep(tmp_path, grid, f"hydra.sweep.dir={sweep}")
    assert proc.returncode == 2, (proc.stdout + proc.stderr)[-4000:]
    assert (f"error: jobs 0 and 1 of this sweep would run in one directory, {sweep / 'noisy_spp4'} "
            f"({key}={values}): hydra.sweep.subdir=${{experiment}}_spp${{budget}} does not hold {key}"
            ) in proc.stderr
    assert "sweep_tag=" in proc.stderr and "Nothing was run" in proc.stderr
    assert "Traceback" not in proc.stderr and "skip:" not in proc.stdout + proc.stderr
    assert not sweep.exists() and not (tmp_path / "data").exists()  # nothing rendered, no sweep folder


@pytest.mark.slow
def test_the_advice_gives_each_job_its_own_directory(tmp_path):
    sweep = tmp_path / "sweep"
    proc = _sweep(tmp_path, "seed=0,1", f"hydra.sweep.dir={sweep}",
                  "hydra.sweep.subdir=${experiment}_spp${budget}_seed${seed}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert all((sweep / f"noisy_spp4_seed{s}" / "metrics.json").is_file() for s in (0, 1))


@pytest.mark.slow
def test_a_read_only_sweep_dir_is_one_error_line_naming_the_key(tmp_path, read_only_dir):
    ro, read_only = read_only_dir
    for sweep, words in ((ro, "is not writable"),
                         (ro / "sw", f"would be made in {ro}, which is not writable")):
        proc = _sweep(tmp_path, f"hydra.sweep.dir={sweep}", wrap=read_only)
        assert proc.returncode == 2, (proc.stdout + proc.stderr)[-3000:]
        assert f"error: hydra.sweep.dir={sweep} {words}" in proc.stderr
        assert "Traceback" not in proc.stderr
    assert list(ro.iterdir()) == [] and not (tmp_path / "data").exists()

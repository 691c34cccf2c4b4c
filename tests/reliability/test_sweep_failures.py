"""A sweep with a failed job runs every job, then exits 1 saying how many failed; a run
pointed at another job's finished run directory is an error, not a silent skip."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from mcd.lit.run_record import JOB_FILE, REQUIRED_KEYS, job_identity
from tests.conftest import compose_cfg, mcd_run

CHOICES = {"data": "tiny"}


def _finished(run_dir: Path, *overrides: str) -> Path:
    """A complete ``metrics.json`` of the job that ``overrides`` describe (as if it had finished earlier),
    with the ``job.json`` record a run writes beside it (a folder of outputs without records is a user's)."""
    run_dir.mkdir(parents=True)
    identity = job_identity(compose_cfg(*overrides), CHOICES)
    (run_dir / JOB_FILE).write_text(json.dumps(identity))
    metrics = {**dict.fromkeys(REQUIRED_KEYS, 0.0), **identity}
    path = run_dir / "metrics.json"
    path.write_text(json.dumps(metrics))
    return path


@pytest.mark.slow
def test_a_sweep_with_a_failed_job_runs_every_job_then_exits_1(tmp_path):
    sweep = tmp_path / "sweep"
    done = _finished(sweep / "1", "+experiment=A", "method.KP=false")  # job 1 finished earlier: skipped
    before = done.read_text()
    proc = mcd_run("-m", "+experiment=A", "method.KP=true,false", f"paths.data_dir={tmp_path / 'data'}",
                   f"hydra.sweep.dir={sweep}", "hydra.sweep.subdir=${hydra.job.num}")
    log = proc.stdout + proc.stderr
    assert proc.returncode == 1, log[-4000:]
    assert "needs method.AS" in json.loads((sweep / "0" / "error.json").read_text())["error"]
    assert "skip:" in log and done.read_text() == before  # job 1 ran (was skipped) after job 0 failed
    assert f"1 job(s) of the sweep in {sweep} failed (each has an error.json): 0;" in log


@pytest.mark.slow
def test_a_run_dir_of_another_experiment_is_not_skipped(tmp_path):
    done = _finished(tmp_path / "run", "+experiment=F")
    before = done.read_text()
    proc = mcd_run("+experiment=A", f"paths.data_dir={tmp_path / 'data'}",
                   f"hydra.run.dir={tmp_path / 'run'}")
    assert proc.returncode != 0 and "skip:" not in proc.stdout + proc.stderr
    assert (f"{tmp_path / 'run'} holds a finished run of another job (experiment: 'F' there, 'A' here; "
            "switches: '111111' there, '100000' here)") in proc.stderr
    assert done.read_text() == before and not (tmp_path / "data").exists()


def test_only_this_sweeps_failures_fail_it_however_close_an_earlier_one_was(tmp_path):
    """:class:`mcd.lit.hydra_callbacks.FailedJobs` counts the ``error.json`` files written during the
    sweep: an earlier sweep's failure in the same folder, written the moment before this one started (the
    same second: a clock with one second of slack counted it, and a rerun of the finished jobs exited 1
    naming it), is not this sweep's; a job of this sweep that fails again (its error.json rewritten) or
    newly is."""
    from omegaconf import OmegaConf

    from mcd.lit.hydra_callbacks import FailedJobs
    from mcd.run import write_error

    sweep = tmp_path / "sweep"
    config = OmegaConf.create({"hydra": {"sweep": {"dir": str(sweep)}}})
    cfg = OmegaConf.create({"x": 1})
    write_error(sweep / "C_spp4", cfg, ["+experiment=C"], ValueError("needs method.AS"))  # an earlier sweep's
    callback = FailedJobs()
    callback.on_multirun_start(config)
    callback.on_multirun_end(config)  # nothing of this sweep failed: no exit
    for job in ("C_spp4", "A_spp4"):  # the same job failing again, then a new one
        callback.on_multirun_start(config)
        write_error(sweep / job, cfg, [f"+experiment={job[0]}"], ValueError("broken"))
        with pytest.raises(SystemExit) as exit_:
            callback.on_multirun_end(config)
        assert exit_.value.code == 1

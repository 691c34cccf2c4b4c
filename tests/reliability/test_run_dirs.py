"""One owner per run directory (mcd/lit/run_dir.py). Two runs started in the
same second get two directories and both keep their results; a ``ckpt_path=auto`` resume of a run directory
another process holds is refused naming the owner's pid; an interrupted run resumed with other settings
is refused naming the keys that differ."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from mcd.run import train_and_test
from tests.conftest import compose_cfg, mcd_run, store32_overrides
from tests.reliability.conftest import FROZEN, interrupted_run

REPO = Path(__file__).resolve().parents[2]

#: Runs ``python -m mcd.run`` with Hydra's clock stopped at one second, so that two processes resolve the
#: default ``hydra.run.dir`` (``outputs/<experiment>/<date>_<time>...``) in the same second.
FROZEN_CLOCK = """
import datetime, runpy, sys
import hydra.core.utils as hydra_utils
class Stopped(datetime.datetime):
    @classmethod
    def now(cls, tz=None):
        return cls(2026, 1, 2, 3, 4, 5)
hydra_utils.datetime = Stopped
sys.argv = ["mcd.run", *sys.argv[1:]]
runpy.run_module("mcd.run", run_name="__main__", alter_sys=True)
"""


def _env() -> dict[str, str]:
    return {**os.environ, "OMP_NUM_THREADS": "1", "HYDRA_FULL_ERROR": "1", "PYTHONPATH": str(REPO)}


@pytest.fixture(scope="module")
def interrupted(cbox_store, tmp_path_factory):
    """A run directory of row A as a killed run leaves it (``interrupted_run`` on the shared store), and its
    overrides."""
    run = tmp_path_factory.mktemp("interrupted")
    return run, interrupted_run(cbox_store[1].data_dir, run)


@pytest.mark.slow
def test_two_runs_started_in_the_same_second_get_two_directories_with_both_results(cbox_store, tmp_path):
    overrides = [*store32_overrides(cbox_store[1].data_dir), *FROZEN, "train.epochs=1"]
    procs = [subprocess.Popen([sys.executable, "-c", FROZEN_CLOCK, *overrides, f"seed={seed}"], cwd=tmp_path,
                              env=_env(), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
             for seed in (0, 1)]
    logs = [p.communicate(timeout=600)[0] for p in procs]
    assert [p.returncode for p in procs] == [0, 0], logs[0][-3000:] + logs[1][-3000:]
    runs = sorted((tmp_path / "outputs" / "A").iterdir())
    assert len(runs) == 2 and all(r.name.startswith("2026-01-02_03-04-05_") for r in runs)
    seeds = sorted(json.loads((r / "metrics.json").read_text())["seed"] for r in runs)
    assert seeds == [0, 1]  # both results kept, one per directory
    for r in runs:
        assert len(pd.read_csv(r / "curve.csv")) == 1  # one validation each, not interleaved


#: A process that owns a run directory (``mcd.lit.run_dir.hold``) until its stdin closes: the owner of
#: :func:`test_an_auto_resume_of_a_directory_in_use_is_refused_naming_the_owner`. Two real ``mcd.run``
#: resumes race (the first may finish before the second has imported torch, and the second then finds a
#: complete run and skips it), so the owner holds the lock for as long as the test needs.
OWNER = """
import sys
from pathlib import Path
from mcd.lit import run_dir

with run_dir.hold(Path(sys.argv[1])):
    print("held", flush=True)
    sys.stdin.read()
"""


@pytest.mark.slow
def test_an_auto_resume_of_a_directory_in_use_is_refused_naming_the_owner(interrupted, tmp_path):
    source, overrides = interrupted
    run = tmp_path / "run"
    shutil.copytree(source, run)
    last = run / "checkpoints" / "last.ckpt"
    before = last.stat().st_mtime_ns
    # the command in the worker (:func:`tests.conftest.mcd_run`): the other run is the owner's process
    args = [*overrides, "train.epochs=3", "ckpt_path=auto", f"hydra.run.dir={run}"]
    owner = subprocess.Popen([sys.executable, "-c", OWNER, str(run)], cwd=REPO, env=_env(),
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert owner.stdout.readline().strip() == "held"
        refused = mcd_run(*args)
    finally:
        owner.communicate(input="", timeout=60)  # closing stdin lets the owner go
    log = refused.stdout + refused.stderr
    assert refused.returncode == 1, log[-3000:]
    assert f"{run} is in use by another run (pid {owner.pid} on " in log
    # the refused process touched nothing: no result, no error record, the interrupted checkpoint as it was
    assert last.stat().st_mtime_ns == before
    assert not (run / "metrics.json").exists() and not (run / "error.json").exists()
    # once the owner is gone the same command resumes the run to its end
    done = mcd_run(*args)
    assert done.returncode == 0, (done.stdout + done.stderr)[-3000:]
    assert json.loads((run / "metrics.json").read_text())["train_steps"] == 3
    assert pd.read_csv(run / "curve.csv")["step"].is_unique


@pytest.mark.slow
def test_an_interrupted_run_resumed_with_other_settings_is_refused_naming_the_keys(interrupted):
    run, overrides = interrupted
    last = run / "checkpoints" / "last.ckpt"
    before = last.stat().st_mtime_ns
    cfg = compose_cfg(*overrides, "train.epochs=2", "seed=3", "budget=8", "ckpt_path=auto")
    with pytest.raises(FileExistsError, match=rf"{run} holds an interrupted run of another job "
                                              r"\(budget: 4 there, 8 here; seed: 0 there, 3 here\)"):
        train_and_test(cfg, run, {"data": "tiny"}, time.perf_counter())
    assert last.stat().st_mtime_ns == before and not (run / "metrics.json").exists()

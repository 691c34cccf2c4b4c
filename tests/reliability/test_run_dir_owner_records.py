"""A run directory's records stay the run's own (docs/reliability.md, "Campaign fixes"):

- a run started again without ``ckpt_path`` in a directory holding an interrupted run (``last.ckpt``, no
  ``metrics.json``) trained from scratch over it: its ``last.ckpt`` was replaced (the training it held lost)
  and its best checkpoint stayed beside the new run's. It is now refused, naming ``ckpt_path=auto``;
- a second ``mcd.run`` on a directory a live run holds was refused by ``run.lock``, but Hydra had already
  written the second process's ``.hydra/config.yaml`` and ``overrides.yaml`` there, so the live run's record
  said ``capacity=paper`` and ``train.max_steps=2`` when it finished. Hydra now writes no ``.hydra/`` into a
  directory in use (``mcd.lit.run_dir.record_subdir``)."""

from __future__ import annotations

import shutil
import subprocess
import sys
import time

import pytest

from mcd.run import train_and_test
from tests.conftest import compose_cfg
from tests.reliability.test_run_dirs import OWNER, REPO, _env, interrupted  # noqa: F401  (a fixture)


@pytest.mark.slow
def test_a_fresh_start_over_an_interrupted_run_is_refused_and_auto_resumes_it(interrupted, tmp_path):  # noqa: F811
    source, overrides = interrupted
    run = tmp_path / "run"
    shutil.copytree(source, run)
    ckpts = {p.name: p.read_bytes() for p in (run / "checkpoints").iterdir()}
    with pytest.raises(FileExistsError, match=rf"{run} holds an interrupted run \(.*last\.ckpt, no "
                                              r"metrics\.json\): resume it with ckpt_path=auto"):
        train_and_test(compose_cfg(*overrides, "train.epochs=2"), run, {"data": "tiny"}, time.perf_counter())
    assert {p.name: p.read_bytes() for p in (run / "checkpoints").iterdir()} == ckpts  # nothing replaced
    done = train_and_test(compose_cfg(*overrides, "train.epochs=2", "ckpt_path=auto"), run, {"data": "tiny"},
                          time.perf_counter())
    assert done["train_steps"] == 2 and [s["start_step"] for s in done["segments"]] == [0, 1]


@pytest.mark.slow
def test_a_second_run_refused_on_a_directory_in_use_leaves_its_hydra_records(interrupted, tmp_path):  # noqa: F811
    source, overrides = interrupted
    run = tmp_path / "run"
    shutil.copytree(source, run)
    (run / ".hydra").mkdir(exist_ok=True)
    for name in ("config.yaml", "overrides.yaml", "hydra.yaml"):
        (run / ".hydra" / name).write_text(f"# the live run's {name}\n")
    records = {p.name: p.read_bytes() for p in (run / ".hydra").iterdir()}
    owner = subprocess.Popen([sys.executable, "-c", OWNER, str(run)], cwd=REPO, env=_env(),
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        assert owner.stdout.readline().strip() == "held"
        refused = subprocess.run([sys.executable, "-m", "mcd.run", *overrides, "train.max_steps=2",
                                  "capacity=paper", f"hydra.run.dir={run}"],
                                 cwd=REPO, env=_env(), capture_output=True, text=True, timeout=600)
    finally:
        owner.communicate(input="", timeout=60)
    log = refused.stdout + refused.stderr
    assert refused.returncode == 1, log[-3000:]
    assert f"{run} is in use by another run (pid {owner.pid} on " in log
    assert {p.name: p.read_bytes() for p in (run / ".hydra").iterdir()} == records
    assert not (run / "error.json").exists() and not (run / "metrics.json").exists()

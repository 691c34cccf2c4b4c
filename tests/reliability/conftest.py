"""Fixtures of the reliability tests: a private copy of the session's rendered 32x32 Cornell-box store, an
interrupted run on it, and a read-only folder for a command."""

from __future__ import annotations

import shlex
import shutil
import subprocess
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from omegaconf import open_dict

from mcd.data import StoreBuilder
from tests.conftest import compose_cfg, store32_overrides

#: Row A on the session's 32x32 store: one training step and one validation per epoch; lr 0 keeps the
#: validation scores constant, so no epoch after the first is a new best (where `last.ckpt` stayed behind).
FROZEN = ["+experiment=A", "data.train_crop=32", "data.val_crop=32", "train.batch_size=1", "train.lr=0",
          "train.lr_min=0", "train.val_every=1", "++train.val_every_steps=null", "++train.patience=null",
          "train.sample_frames=[]",
          "trainer.enable_progress_bar=false"]
#: The config group choices an interrupted run records, as ``mcd.run`` passes them.
CHOICES = {"data": "tiny"}


@pytest.fixture
def own_store(cbox_store, tmp_path):
    """``(cfg, store)``: a copy of ``cbox_store`` (every buffer, 12 frames) in ``tmp_path``, to damage."""
    cfg, shared = cbox_store
    shutil.copytree(shared.data_dir, tmp_path / "data")
    cfg = cfg.copy()
    with open_dict(cfg):
        cfg.paths.data_dir = str(tmp_path / "data")
    return cfg, StoreBuilder.from_cfg(cfg)


def interrupted_run(data_dir: Path, run: Path) -> list[str]:
    """Row A (:data:`FROZEN`) trained one epoch on the store in ``data_dir`` into ``run`` and left as a run
    killed after its checkpoint leaves it (``checkpoints/last.ckpt``, no ``metrics.json``); its overrides, to
    which a resume adds ``train.epochs=2 ckpt_path=auto``."""
    from mcd.run import train_and_test

    overrides = [*store32_overrides(data_dir), *FROZEN]
    train_and_test(compose_cfg(*overrides, "train.epochs=1"), run, CHOICES, time.perf_counter())
    (run / "metrics.json").unlink()
    return overrides


@pytest.fixture
def own_interrupted(own_store, tmp_path) -> tuple[Path, list[str], StoreBuilder]:
    """``(run, overrides, store)``: :func:`interrupted_run` on ``own_store``, in ``tmp_path / "run"``, for a
    test that resumes it."""
    _, store = own_store
    run = tmp_path / "run"
    return run, interrupted_run(store.data_dir, run), store


@pytest.fixture
def read_only_dir(tmp_path) -> tuple[Path, Callable[[list[str]], list[str]]]:
    """``(folder, wrap)``: an empty folder ``tmp_path / "ro"``, and ``wrap(argv)``, the command line that runs
    ``argv`` with that folder bind-mounted read-only in a private mount namespace (``unshare -rm``). Skips
    where the machine cannot make one."""
    if subprocess.run(["unshare", "-rm", "true"], capture_output=True).returncode != 0:
        pytest.skip("no unprivileged mount namespace here (unshare -rm) to make a read-only mount")
    ro = tmp_path / "ro"
    ro.mkdir()
    q = shlex.quote(str(ro))

    def wrap(argv: list[str]) -> list[str]:
        script = f"mount --bind {q} {q} && mount -o remount,ro,bind {q} && exec {shlex.join(argv)}"
        return ["unshare", "-rm", "sh", "-c", script]

    return ro, wrap

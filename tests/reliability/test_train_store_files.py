"""The training store's own files (mcd/data/train_store.py, mcd/data/pack.py,
docs/training_store.md). Defect 19: a corrupt ``store.json`` or ``<scene>.json`` gave a JSONDecodeError or
KeyError traceback; it is named with its fix, and following the fix packs again. Real renders, real packs."""

from __future__ import annotations

import json
import os
import shlex
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mcd.data import BUFFERS
from mcd.data.pack import pack
from mcd.data.train_store import TrainStore, TrainStoreError, TrainStoreSettings
from tests.conftest import compose_cfg, store32_overrides

ROOT = Path(__file__).resolve().parents[2]


def _cfg(data_dir, folder, *more):
    return compose_cfg(*store32_overrides(data_dir), "data.train_store.format=array",
                       f"data.train_store.dir={folder}", *more)


DAMAGE = {
    "store_truncated": ("store.json", '{"version": 1, "dty'),
    "store_a_list": ("store.json", "[1, 2]"),
    "store_no_channels": ("store.json", None),  # a valid JSON object without the key
    "record_bytes": ("cbox.json", np.random.default_rng(0).bytes(300)),
    "record_frames_list": ("cbox.json", '{"frames": [1, 2]}'),
}


@pytest.mark.parametrize("damage", list(DAMAGE))
def test_defect19_a_corrupt_store_or_scene_record_is_named_with_its_fix(cbox_store, tmp_path, damage):
    _, store = cbox_store
    folder = tmp_path / "ts"
    cfg = _cfg(store.data_dir, folder)
    assert pack(cfg, store, BUFFERS)["packed"] == 10
    name, content = DAMAGE[damage]
    path = folder / name
    if content is None:
        meta = json.loads(path.read_text())
        del meta["channels"]
        content = json.dumps(meta)
    path.write_bytes(content if isinstance(content, bytes) else content.encode())
    with pytest.raises(TrainStoreError) as err:
        pack(cfg, store, BUFFERS)
    message = str(err.value)
    assert message.startswith(f"{path} is corrupt (") and "python -m mcd.pack" in message, message
    if name == "store.json":  # what training opens, too
        with pytest.raises(TrainStoreError, match="is corrupt"):
            TrainStore.open(TrainStoreSettings.from_cfg(cfg), cfg.data, BUFFERS, "pack")
        assert f"delete {folder} and pack it again" in message
        shutil.rmtree(folder)
    else:
        assert "delete it and pack again" in message
        path.unlink()
    assert pack(cfg, store, BUFFERS)["packed"] == 10  # the fix, followed


def _in_read_only_mount(folder, argv, cwd):
    """Run ``argv`` where ``folder`` is a read-only bind mount (a private mount namespace: ``unshare -rm``,
    no privilege needed where user namespaces are on); None where this machine cannot make one."""
    probe = subprocess.run(["unshare", "-rm", "true"], capture_output=True)
    if probe.returncode != 0:
        return None
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    where = shlex.quote(str(folder))
    script = f"mount --bind -o ro {where} {where} && exec {shlex.join(argv)}"
    return subprocess.run(["unshare", "-rm", "sh", "-c", script], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=600)


@pytest.mark.parametrize("command", ["mcd.pack", "mcd.run"])
@pytest.mark.slow
def test_defect20_a_fully_packed_read_only_store_is_trained_from(cbox_store, tmp_path, command):
    _, store = cbox_store
    folder = tmp_path / "ts"
    overrides = [*store32_overrides(store.data_dir), "data.train_store.format=array",
                 f"data.train_store.dir={folder}", "+experiment=unet", "capacity=cpu"]
    cfg = compose_cfg(*overrides)
    assert pack(cfg, store, BUFFERS)["packed"] == 10
    (folder / "cbox.lock").unlink()  # as a store copied onto a read-only mount may come: no lock file
    before = {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}
    more = ["render.buffers=all"] if command == "mcd.pack" else [
        "train.max_steps=2", "train.batch_size=1", f"hydra.run.dir={tmp_path / 'run'}"]
    proc = _in_read_only_mount(folder, [sys.executable, "-m", command, *overrides, *more], tmp_path)
    if proc is None:
        pytest.skip("no unprivileged mount namespace here (unshare -rm) to make a read-only mount")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr and "Read-only file system" not in proc.stderr
    assert "packed 0 frame(s), reused 10" in proc.stdout + proc.stderr
    assert {p.name: p.stat().st_mtime_ns for p in folder.iterdir()} == before
    if command == "mcd.run":  # trained and tested from the read-only store
        assert json.loads((tmp_path / "run" / "metrics.json").read_text())["train_steps"] == 2


@pytest.mark.parametrize("where", ["a_file", "below_a_file"])
def test_defect21_a_store_dir_that_is_or_lies_below_a_file_is_named_before_rendering(tmp_path, where):
    from mcd.run import train_and_test

    (tmp_path / "file").write_text("not a folder")
    given = tmp_path / "file" if where == "a_file" else tmp_path / "file" / "ts"
    cfg = _cfg(tmp_path / "data", given, "+experiment=unet", "capacity=cpu")
    why = "is a file" if where == "a_file" else f"lies below {tmp_path / 'file'}, which is a file"
    with pytest.raises(ValueError, match=f"^data.train_store.dir={given} {why}, not a folder"):
        train_and_test(cfg, tmp_path / "run", {}, time.perf_counter())
    with pytest.raises(ValueError, match="^data.train_store.dir="):  # and the pack command's first step
        TrainStoreSettings.from_cfg(cfg)
    assert not (tmp_path / "data").exists()  # nothing rendered
    assert (tmp_path / "file").read_text() == "not a folder"

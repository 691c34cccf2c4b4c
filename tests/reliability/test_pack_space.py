"""A pack onto a full disk died with SIGBUS (exit 135) and an empty log: the scene
arrays are memory maps, and a write into one past a full disk kills the process. The pack checks the free
space of ``data.train_store.dir``'s disk before it writes anything, and names the need (mcd/data/pack.py).

Two tests: ``python -m mcd.pack`` for real onto a 64 KB tmpfs, mounted in a private mount namespace
(``unshare -rm``; skipped where the machine cannot make one), and the same check in process with
``shutil.disk_usage`` reporting a nearly full disk (runs everywhere). A third: a disk that fills after the
check, the pack's write failing part-way on a 2 MB tmpfs, names the file and the frame (mcd/data/pack.py
writes frames with ``os.pwrite``; a write through a memory map died of SIGBUS there too)."""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from collections import namedtuple
from pathlib import Path

import pytest

from mcd.data import BUFFERS
from mcd.data.pack import pack
from tests.conftest import compose_cfg, store32_overrides

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_defect8_a_pack_onto_a_full_tmpfs_names_the_need_instead_of_dying(cbox_store, tmp_path):
    if subprocess.run(["unshare", "-rm", "true"], capture_output=True).returncode != 0:
        pytest.skip("no unprivileged mount namespace here (unshare -rm) to mount a small tmpfs")
    _, store = cbox_store
    folder = tmp_path / "ts"
    folder.mkdir()
    argv = [sys.executable, "-m", "mcd.pack", *store32_overrides(store.data_dir),
            "data.train_store.format=array", f"data.train_store.dir={folder}", "render.buffers=all"]
    script = f"mount -t tmpfs -o size=64k tmpfs {shlex.quote(str(folder))} && exec {shlex.join(argv)}"
    proc = subprocess.run(["unshare", "-rm", "sh", "-c", script], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode == 1, (proc.returncode, proc.stderr[-3000:])  # not -7 / 135 (SIGBUS)
    assert f"data.train_store.dir={folder}: packing 10 frame(s) needs " in proc.stderr, proc.stderr[-3000:]
    assert "MB free; free space there" in proc.stderr


def test_defect8_the_free_space_check_runs_before_anything_is_written(cbox_store, tmp_path, monkeypatch):
    _, store = cbox_store
    folder = tmp_path / "ts"
    cfg = compose_cfg(*store32_overrides(store.data_dir), "data.train_store.format=array",
                      f"data.train_store.dir={folder}")
    usage = namedtuple("usage", "total used free")
    monkeypatch.setattr(shutil, "disk_usage", lambda path: usage(10**9, 10**9 - 1000, 1000))
    with pytest.raises(OSError, match=rf"data.train_store.dir={folder}: packing 10 frame\(s\) needs .* MB "
                                      r"and its disk \(.*\) has 0.0 MB free"):
        pack(cfg, store, BUFFERS)
    assert not folder.exists()  # nothing written
    monkeypatch.undo()
    assert pack(cfg, store, BUFFERS)["packed"] == 10  # with room, the same pack goes ahead


@pytest.mark.slow
def test_a_disk_that_fills_after_the_check_stops_the_pack_naming_the_frame_and_records_nothing_of_it(
        cbox_store, tmp_path):
    """The free-space check passed (``shutil.disk_usage`` reports a terabyte free: the disk fills after it, as
    when another process writes there) and the 2 MB tmpfs fills at the fourth of the 10 frames (540 KB each):
    the write fails with an error naming the file and the frame, exit 1, and the record lists only the frames
    before it (a write through the memory map died of SIGBUS here)."""
    if subprocess.run(["unshare", "-rm", "true"], capture_output=True).returncode != 0:
        pytest.skip("no unprivileged mount namespace here (unshare -rm) to mount a small tmpfs")
    _, store = cbox_store
    folder = tmp_path / "ts"
    folder.mkdir()
    argv = ["mcd.pack", *store32_overrides(store.data_dir), "data.train_store.format=array",
            f"data.train_store.dir={folder}", "render.buffers=all"]
    code = ("import collections, runpy, shutil, sys; "
            "usage = collections.namedtuple('usage', 'total used free'); "
            "shutil.disk_usage = lambda path: usage(10**12, 0, 10**12); "
            f"sys.argv = {argv!r}; runpy.run_module('mcd.pack', run_name='__main__')")
    q = shlex.quote(str(folder))
    script = (f"mount -t tmpfs -o size=2m tmpfs {q} && {shlex.join([sys.executable, '-c', code])}; rc=$?; "
              f"echo RECORD; cat {q}/cbox.json; exit $rc")
    proc = subprocess.run(["unshare", "-rm", "sh", "-c", script], cwd=tmp_path, capture_output=True,
                          text=True, timeout=600, env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert proc.returncode == 1, (proc.returncode, proc.stderr[-3000:])  # not -7 / 135 (SIGBUS)
    found = re.search(rf"{re.escape(str(folder / 'cbox.npy'))}: frame (\d+) could not be written \(No space "
                      r"left on device\); nothing was recorded for it", proc.stderr)
    assert found, proc.stderr[-3000:]
    recorded = sorted(int(f) for f in json.loads(proc.stdout.split("RECORD\n")[-1])["frames"])
    assert recorded == list(range(2, int(found[1]))) and len(recorded) >= 2

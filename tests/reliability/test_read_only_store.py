"""Campaign 8 (docs/reliability.md): a fully rendered EXR store on a read-only mount is trained from.
``mcd.run`` took every scene's ``<scene>/.lock`` and saved its manifest even when nothing needed rendering,
and died on ``OSError: [Errno 30] Read-only file system: '.../cbox/.lock'`` before training (the training
store's pack had the same fault, fixed in round 4). A scene whose every file is rendered for the config and
whose manifest needs no change is now found so by reading alone and reused without the lock
(``StoreBuilder._rendered_already``); the store's files keep their bytes."""

from __future__ import annotations

import hashlib
import shlex
import shutil
import subprocess
import sys

import pytest

from tests.conftest import module_env, store32_overrides


@pytest.mark.slow
def test_a_fully_rendered_store_on_a_read_only_mount_is_trained_from(cbox_store, tmp_path):
    if subprocess.run(["unshare", "-rm", "true"], capture_output=True).returncode != 0:
        pytest.skip("no unprivileged mount namespace here (unshare -rm) to make a read-only mount")
    data = tmp_path / "data"
    shutil.copytree(cbox_store[1].data_dir, data)
    before = {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in data.rglob("*") if p.is_file()}
    run = tmp_path / "run"
    argv = [sys.executable, "-m", "mcd.run", "+experiment=unet", *store32_overrides(data),
            "train.max_steps=1", "train.sample_frames=[]", "trainer.enable_progress_bar=false",
            f"hydra.run.dir={run}"]
    q = shlex.quote(str(data))
    script = f"mount --bind {q} {q} && mount -o remount,ro,bind {q} && exec {shlex.join(argv)}"
    proc = subprocess.run(["unshare", "-rm", "sh", "-c", script], cwd=tmp_path, env=module_env(),
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert (run / "metrics.json").is_file()
    assert {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in data.rglob("*") if p.is_file()} == before

"""The fix command of a damaged file repeats the overrides that made the store
(following it repairs that store, not another one), and a damaged ``manifest.json`` is named with its fix,
which ``render.verify=true`` (or ``--force``) carries out."""

from __future__ import annotations

import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from hydra.core.hydra_config import HydraConfig
from omegaconf import open_dict

from mcd.data import CorruptEXRError, StoreBuilder
from mcd.data.store import CorruptManifestError
from tests.conftest import CONF_DIR, store32_overrides

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_following_the_fix_command_repairs_the_same_store(own_store, tmp_path):
    cfg, _ = own_store
    overrides = [*store32_overrides(cfg.paths.data_dir), "+experiment=F", "train.epochs=1"]
    store = StoreBuilder.from_cfg(cfg, overrides)
    damaged = store.path("cbox", 1, "c4")
    damaged.write_bytes(damaged.read_bytes()[:100])
    with pytest.raises(CorruptEXRError) as err:
        store.load("cbox", 1, "c4")
    fix = err.value.fix.removesuffix(" (re-renders damaged files)")
    args = shlex.split(fix)
    assert args[:3] == ["python", "-m", "mcd.render"] and "render.buffers=[c4]" in args
    assert "data.width=32" in args and "+experiment=F" not in args  # the store's overrides, not the run's
    others = {p: p.stat().st_mtime_ns for p in store.root.rglob("*.exr") if p != damaged}
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, *args[1:], f"hydra.run.dir={tmp_path / 'log'}"], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert StoreBuilder.from_cfg(cfg).load("cbox", 1, "c4").shape == (32, 32, 3)  # repaired, store's size
    assert {p: p.stat().st_mtime_ns for p in others} == others  # nothing else re-rendered


def test_a_hydra_apps_overrides_reach_the_fix_command(tmp_path):
    overrides = [*store32_overrides(tmp_path), "+experiment=F", "+scene@data.scenes.extra=cbox"]
    with initialize_config_dir(config_dir=CONF_DIR, version_base=None):
        cfg = compose("config", overrides=overrides, return_hydra_config=True)
    HydraConfig.instance().set_config(cfg)
    try:
        store = StoreBuilder.from_cfg(cfg)
    finally:
        HydraConfig.instance().cfg = None
    shaping = [o for o in overrides if not o.startswith(("+experiment=", "paths.data_dir="))]
    assert store.overrides == [*shaping, f"paths.data_dir={tmp_path}"]


@pytest.mark.slow
def test_a_garbage_manifest_is_named_with_its_fix_which_verify_carries_out(own_store, caplog):
    cfg, store = own_store
    manifest = store.manifest_path("cbox")
    manifest.write_text('{"version": 1, "files": {"0000/ref.e')  # truncated
    named = rf"{re.escape(str(manifest))}: truncated or corrupt manifest .*render\.verify=true"
    with pytest.raises(CorruptManifestError, match=named):
        StoreBuilder.from_cfg(cfg).load("cbox", 0, "ref")
    with pytest.raises(CorruptManifestError):
        StoreBuilder.from_cfg(cfg).ensure({"c1"}, progress=False)
    with open_dict(cfg):
        cfg.render.verify = True
    report = StoreBuilder.from_cfg(cfg).ensure({"c1"}, progress=False)
    assert report["rendered"] == {"ref": 12, "c1": 12}
    assert StoreBuilder.from_cfg(cfg).load("cbox", 0, "c1").shape == (32, 32, 3)

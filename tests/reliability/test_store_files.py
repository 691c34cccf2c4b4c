"""Store files get the umask's mode, stale temp files beside the manifest are
removed, and two concurrent renders of one store both finish with a complete manifest."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from mcd.data import StoreBuilder
from tests.conftest import compose_cfg, store32_overrides

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(("umask", "mode"), [(0o022, 0o644), (0o027, 0o640)])
def test_store_files_get_the_umasks_mode(own_store, umask, mode):
    cfg, store = own_store
    store.path("cbox", 0, "c1").unlink()  # one file to render again
    old = os.umask(umask)
    try:
        report = StoreBuilder.from_cfg(cfg).ensure({"c1"}, progress=False)
    finally:
        os.umask(old)
    assert report["rendered"] == {"c1": 1}
    for path in (store.path("cbox", 0, "c1"), store.manifest_path("cbox")):
        assert path.stat().st_mode & 0o777 == mode, path


def test_a_stale_manifest_temp_file_is_removed(own_store):
    cfg, store = own_store
    scene = store.root / "cbox"
    stale = [scene / ".manifest.json.abc123.tmp", scene / "0003" / ".ref.exr.x.tmp.exr"]
    for path in stale:
        path.write_text("left by a killed render")
    report = StoreBuilder.from_cfg(cfg).ensure({"c1"}, progress=False)
    assert report["rendered"] == {} and not any(p.exists() for p in stale)


def _render(data_dir: Path, buffers: str) -> subprocess.Popen:
    args = [a for a in store32_overrides(data_dir) if a != "data.ref_spp=256"]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "HYDRA_FULL_ERROR": "1"}
    return subprocess.Popen(
        [sys.executable, "-m", "mcd.render", *args, "data.ref_spp=1024", f"render.buffers={buffers}",
         f"hydra.run.dir={data_dir.parent / ('log_' + buffers.strip('[]'))}"],
        cwd=REPO, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)


@pytest.mark.slow
def test_two_concurrent_renders_of_one_store_both_finish_with_a_complete_manifest(tmp_path):
    data = tmp_path / "data"
    procs = [_render(data, "[c4]"), _render(data, "[c8]")]  # both render ref too: same files, same scene
    outs = [p.communicate(timeout=600)[0] for p in procs]
    assert [p.returncode for p in procs] == [0, 0], "\n".join(o[-3000:] for o in outs)
    files = json.loads((data / "test32" / "cbox" / "manifest.json").read_text())["files"]
    for buffer in ("ref", "c4", "c8"):
        assert sum(k.endswith(f"/{buffer}.exr") for k in files) == 12, buffer
    cfg = compose_cfg(*[a for a in store32_overrides(data) if a != "data.ref_spp=256"], "data.ref_spp=1024")
    assert StoreBuilder.from_cfg(cfg).ensure({"c4", "c8"}, progress=False)["rendered"] == {}  # nothing lost

"""Sharded rendering: ``render.shard`` / ``render.scenes`` / ``render.frames`` pick
disjoint parts of a profile (mcd/data/shards.py); shards rendered by several processes at once into one store
end with the store one process renders, and a killed shard resumes (docs/scale.md, "Render in shards")."""

from __future__ import annotations

import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from mcd.data import StoreBuilder
from mcd.data.shards import Selection
from tests.conftest import compose_cfg, store32_overrides

REPO = Path(__file__).resolve().parents[2]
BUFFERS = "[c1,depth,motion]"  # + ref: a colour buffer, the G-buffer of frame 0's depth scale, motion
ASKED = {"c1", "depth", "motion"}


def _sel(**render) -> Selection:
    return Selection.from_render_cfg(OmegaConf.create(render), ["cbox", "staircase2"], 12)


def test_shards_are_disjoint_and_cover_the_selection():
    everything = {(s, f) for s, fs in _sel().units(["cbox", "staircase2"], 12).items() for f in fs}
    assert len(everything) == 24
    for n in (1, 2, 3, 5, 64):
        parts = [{(s, f) for s, fs in _sel(shard=f"{i}/{n}").units(["cbox", "staircase2"], 12).items()
                  for f in fs} for i in range(n)]
        assert set().union(*parts) == everything and sum(map(len, parts)) == 24, n
        assert max(map(len, parts)) - min(map(len, parts)) <= 1, n  # balanced
    assert _sel(shard=2, shards=3).units(["cbox"], 12) == _sel(shard="2/3").units(["cbox"], 12)
    narrowed = _sel(shard="1/2", scenes=["staircase2"], frames="4:9").units(["cbox", "staircase2"], 12)
    assert narrowed == {"staircase2": [5, 7]}
    assert _sel(frames=":3").frames == (0, 3) and _sel(frames="10:").frames == (10, 12)


@pytest.mark.parametrize(("render", "key"), [
    ({"shard": "3/3"}, "render.shard"),
    ({"shard": "-1/3"}, "render.shard"),
    ({"shard": "1of3"}, "render.shard"),
    ({"shard": "0/0"}, "render.shard"),
    ({"shard": 1}, "render.shard"),
    ({"shard": "1/4", "shards": 3}, "render.shards"),
    ({"shards": 4}, "render.shards"),
    ({"frames": "10:13"}, "render.frames"),
    ({"frames": "5:5"}, "render.frames"),
    ({"frames": "a:b"}, "render.frames"),
    ({"scenes": ["kitchen"]}, "render.scenes"),
    ({"scenes": []}, "render.scenes"),
])
def test_bad_selection_is_refused_naming_the_key(render, key):
    with pytest.raises(ValueError, match=re.escape(key)):
        _sel(**render)


def test_mcd_render_refuses_a_bad_shard_before_any_work(tmp_path):
    from mcd.render import main

    cfg = compose_cfg(*store32_overrides(tmp_path), "render.shard=4/4")
    with pytest.raises(ValueError, match=r"render\.shard='4/4'.*out of range"):
        main(cfg)
    assert not (tmp_path / "test32").exists()


def _overrides(data_dir: Path, ref_spp: int = 1024) -> list[str]:
    """The 32x32 Cornell box store's overrides with ``ref_spp`` reference samples: 1024 by default, so that a
    shard renders long enough to be killed mid-run; bit-identity does not depend on it."""
    return [*[a for a in store32_overrides(data_dir) if a != "data.ref_spp=256"], f"data.ref_spp={ref_spp}",
            f"render.buffers={BUFFERS}"]


def _env() -> dict[str, str]:
    return {**os.environ, "OMP_NUM_THREADS": "1", "HYDRA_FULL_ERROR": "1",
            "PYTHONPATH": f"{REPO}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}


def _store_files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*.exr"))}


@pytest.mark.slow
def test_three_shards_two_processes_at_once_equal_a_one_process_render(tmp_path):
    """A Hydra multirun on the joblib launcher renders the three shards of the Cornell box profile, two
    processes at a time, into one store: the same manifest entries, scene facts and file bytes as one process
    (the Cornell box renders bit-identically across processes), every unit rendered exactly once."""
    sharded, single = tmp_path / "sharded", tmp_path / "single"
    sweep = tmp_path / "sweep"
    proc = subprocess.run(
        [sys.executable, "-m", "mcd.render", "-m", *_overrides(sharded, 256), "render.shard=0/3,1/3,2/3",
         "hydra/launcher=joblib", "hydra.launcher.n_jobs=2", f"hydra.sweep.dir={sweep}"],
        cwd=REPO, env=_env(), capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    StoreBuilder.from_cfg(compose_cfg(*_overrides(single, 256))).ensure(ASKED, progress=False)

    one = json.loads((single / "test32" / "cbox" / "manifest.json").read_text())
    many = json.loads((sharded / "test32" / "cbox" / "manifest.json").read_text())
    assert len(one["files"]) == 12 * 4  # ref, c1, depth, motion
    assert many["files"] == one["files"]  # no entry lost, each the same as one process's
    for key in ("exposure", "depth_scale", "ref_quality", "cameras"):
        assert many[key] == one[key], key
    assert _store_files(sharded / "test32") == _store_files(single / "test32")
    logs = "".join(p.read_text() for p in sweep.glob("*/*.log"))
    counts = re.findall(r"rendered ([^;]*);", logs)
    assert len(counts) == 3, logs[-3000:]
    total: dict[str, int] = {}
    for line in counts:
        for buffer, n in re.findall(r"(\w+) x(\d+)", line):
            total[buffer] = total.get(buffer, 0) + int(n)
    assert total == {"ref": 12, "c1": 12, "depth": 12, "motion": 12}  # nothing rendered twice
    assert not list((sharded / "test32").rglob(".*.tmp*"))


@pytest.mark.slow
def test_a_killed_shard_resumes_beside_a_live_one(tmp_path):
    """Shards 0/2 and 1/2 render at once; shard 0 is killed (SIGKILL) mid-run. Shard 1 finishes, shard 0
    run again renders only what it lacked: the finished frames of both stay as they were, and the manifest
    ends complete."""
    args = _overrides(tmp_path)
    procs = [subprocess.Popen([sys.executable, "-m", "mcd.render", *args, f"render.shard={i}/2",
                               f"hydra.run.dir={tmp_path}/h{i}"], cwd=REPO, env=_env(),
                              stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL) for i in (0, 1)]
    manifest = tmp_path / "test32" / "cbox" / "manifest.json"
    mine = {f"{f:04d}" for f in range(0, 12, 2)}  # shard 0's frames
    deadline = time.time() + 300
    while time.time() < deadline and procs[0].poll() is None:
        if manifest.is_file():
            done = json.loads(manifest.read_text())["files"]
            if len({k.split("/")[0] for k in done if k.endswith("motion.exr")} & mine) >= 2:
                break
        time.sleep(0.05)
    assert procs[0].poll() is None, "shard 0 finished before it could be killed"
    procs[0].send_signal(signal.SIGKILL)
    procs[0].wait()
    assert procs[1].wait(timeout=600) == 0
    done = json.loads(manifest.read_text())["files"]
    assert 2 <= len({k.split("/")[0] for k in done if k.endswith("motion.exr")} & mine) < 6
    root = manifest.parent
    mtimes = {k: (root / k).stat().st_mtime_ns for k in done}
    resumed = StoreBuilder.from_cfg(compose_cfg(*args)).ensure(
        ASKED, progress=False, selection=Selection(0, 2))
    assert sum(resumed["rendered"].values()) + sum(resumed["reused"].values()) == 6 * 4
    assert sum(resumed["rendered"].values()) == 6 * 4 - len([k for k in done if k.split("/")[0] in mine])
    assert all((root / k).stat().st_mtime_ns == t for k, t in mtimes.items())
    files = json.loads(manifest.read_text())["files"]
    assert len(files) == 12 * 4
    assert not list(root.rglob(".*.tmp*"))
    assert StoreBuilder.from_cfg(compose_cfg(*args)).ensure(ASKED, progress=False)["rendered"] == {}

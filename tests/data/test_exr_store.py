"""The EXR store: atomic writes, corrupt files named with their fix, resume, only what is asked."""

from __future__ import annotations

import json
import logging
import shlex

import numpy as np
import pytest

from mcd.data import CorruptEXRError, StoreBuilder
from mcd.data.exr import count_bad, read_exr, sanitise, write_exr
from mcd.data.renderer import SceneRenderer
from tests.conftest import compose_cfg, store32_overrides

FAST = ["data.ref_spp=8", "data.gbuffer_spp=2"]


def _store(tmp_path, *extra: str) -> StoreBuilder:
    """The 32x32 test store with every reference at ``data.ref_spp``: these tests count renders and files;
    reference quality has its own (tests/data/test_reference_quality.py)."""
    return StoreBuilder.from_cfg(
        compose_cfg(*store32_overrides(tmp_path), *FAST, "data.ref_quality.target_db=null", *extra))


@pytest.mark.parametrize("channels", [1, 2, 3])
def test_exr_roundtrip_hdr_and_odd_size(tmp_path, channels):
    img = np.random.default_rng(0).random((7, 13, channels)).astype(np.float32) * 1e5
    img[0, 0] = 0.0
    p = tmp_path / "a.exr"
    write_exr(p, img)
    assert np.array_equal(read_exr(p), img)
    assert [f.name for f in tmp_path.iterdir()] == ["a.exr"]  # no temporary file left behind


def test_truncated_exr_raises_named_error(tmp_path):
    p = tmp_path / "t.exr"
    write_exr(p, np.ones((16, 16, 3), np.float32))
    p.write_bytes(p.read_bytes()[:40])
    with pytest.raises(CorruptEXRError, match="t.exr"):
        read_exr(p)


def test_sanitise_counts():
    img = np.array([[[np.nan, np.inf, -1.0], [0.5, -np.inf, 2.0]]], np.float32)
    assert count_bad(img, allow_negative=False) == {"nan": 1, "inf": 2, "negative": 1}
    clean, n = sanitise(img, allow_negative=False)
    assert n == 4 and np.isfinite(clean).all() and (clean >= 0).all() and clean[0, 1, 2] == 2.0
    assert sanitise(np.array([-1.0, 1.0], np.float32), allow_negative=True)[1] == 0


def test_only_requested_buffers_are_rendered(tmp_path, caplog):
    store = _store(tmp_path)
    with caplog.at_level(logging.INFO, logger="mcd.data.store"):
        summary = store.ensure({"c2"}, progress=False)
    assert summary["rendered"] == {"ref": 12, "c2": 12}
    names = {p.name for p in (tmp_path / "test32" / "cbox").rglob("*.exr")}
    assert names == {"c2.exr", "ref.exr"}  # a c2 run never renders c32, c1_in or G-buffers
    assert any("rendered c2 x12, ref x12" in r.getMessage() for r in caplog.records)
    again = store.ensure({"c2"}, progress=False)
    assert again["rendered"] == {} and again["reused"] == {"ref": 12, "c2": 12}
    man = json.loads((tmp_path / "test32" / "cbox" / "manifest.json").read_text())
    rec = man["files"]["0003/c2.exr"]
    assert (
        rec["spp"] == 2
        and len(rec["sha256"]) == 64
        and man["mitsuba"]
        and man["settings"]["rfilter"] == "box"
    )
    seeds = {r["seed"] for r in man["files"].values()}
    assert len(seeds) == 24  # an independent seed per image


def test_force_rerenders(tmp_path):
    store = _store(tmp_path)
    store.ensure({"c1"}, progress=False)
    forced = _store(tmp_path, "render.force=true").ensure({"c1"}, progress=False)
    assert forced["rendered"] == {"ref": 12, "c1": 12}


@pytest.mark.slow
def test_interrupted_render_resumes(tmp_path, monkeypatch):
    store = _store(tmp_path)
    calls = {"n": 0}
    real = SceneRenderer.color

    def flaky(self, spp, seed):
        calls["n"] += 1
        if calls["n"] == 8:  # 2 colour renders per frame (ref, c4): dies inside frame 3
            raise KeyboardInterrupt
        return real(self, spp, seed)

    monkeypatch.setattr(SceneRenderer, "color", flaky)
    with pytest.raises(KeyboardInterrupt):
        store.ensure({"c4"}, progress=False)
    monkeypatch.setattr(SceneRenderer, "color", real)
    root = tmp_path / "test32" / "cbox"
    done = json.loads((root / "manifest.json").read_text())["files"]
    assert sorted(done) == [f"{f:04d}/{b}.exr" for f in range(3) for b in ("c4", "ref")]
    mtimes = {k: (root / k).stat().st_mtime_ns for k in done}
    resumed = _store(tmp_path).ensure({"c4"}, progress=False)
    assert resumed["rendered"] == {"ref": 9, "c4": 9} and resumed["reused"] == {"ref": 3, "c4": 3}
    assert all((root / k).stat().st_mtime_ns == t for k, t in mtimes.items())


@pytest.mark.parametrize(("change", "again"), [
    ("data.ref_spp=16", {"ref": 12}),                        # only the reference depends on ref_spp
    ("data.gbuffer_spp=4", {"depth": 12, "motion": 12}),     # G-buffers, and motion through depth
    ("data.seed=1", {"ref": 12, "c4": 12, "depth": 12, "motion": 12}),  # every image's seed
])
@pytest.mark.slow
def test_a_changed_setting_rerenders_exactly_what_depends_on_it(tmp_path, change, again):
    first = _store(tmp_path).ensure({"c4", "motion"}, progress=False)
    assert first["rendered"] == {"ref": 12, "c4": 12, "depth": 12, "motion": 12}
    changed = _store(tmp_path, change).ensure({"c4", "motion"}, progress=False)
    assert changed["rendered"] == again
    assert _store(tmp_path, change).ensure({"c4", "motion"}, progress=False)["rendered"] == {}


def test_truncated_store_file_is_named_and_repaired(tmp_path):
    store = _store(tmp_path)
    store.ensure({"c4"}, progress=False)
    p = tmp_path / "test32" / "cbox" / "0001" / "c4.exr"
    p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    with pytest.raises(CorruptEXRError) as err:
        _store(tmp_path).load("cbox", 1, "c4")
    assert str(p) in str(err.value) and "python -m mcd.render data.name=test32 data.width=32" in str(
        err.value
    )
    fixed = _store(tmp_path).ensure({"c4"}, progress=False)
    assert fixed["rendered"] == {"c4": 1}
    assert _store(tmp_path).load("cbox", 1, "c4").shape == (32, 32, 3)


def test_bitflip_detected_by_checksum(tmp_path):
    store = _store(tmp_path)
    store.ensure({"c1"}, progress=False)
    p = tmp_path / "test32" / "cbox" / "0002" / "c1.exr"
    data = bytearray(p.read_bytes())
    data[-20] ^= 0xFF
    p.write_bytes(bytes(data))
    with pytest.raises(CorruptEXRError, match="checksum"):
        _store(tmp_path).load("cbox", 2, "c1", verify=True)
    assert _store(tmp_path, "render.verify=true").ensure({"c1"}, progress=False)["rendered"] == {"c1": 1}


def test_bad_pixels_counted_and_sanitised(tmp_path, monkeypatch, caplog):
    real = SceneRenderer.color

    def poisoned(self, spp, seed):
        img = real(self, spp, seed)
        if spp == 4:
            img[0, 0, 0], img[1, 1, 1], img[2, 2, 2] = np.nan, np.inf, -3.0
        return img

    monkeypatch.setattr(SceneRenderer, "color", poisoned)
    store = _store(tmp_path, "data.segments=1", "data.frames_per_segment=2")
    store.ensure({"c4"}, progress=False)
    rec = store.manifest("cbox")["files"]["0001/c4.exr"]
    assert (rec["nan"], rec["inf"], rec["negative"]) == (1, 1, 1)
    with caplog.at_level(logging.WARNING, logger="mcd.data.store"):
        img = store.load("cbox", 1, "c4")
        store.load("cbox", 1, "c4")
    assert np.isfinite(img).all() and (img >= 0).all()
    lines = [r.getMessage() for r in caplog.records if "0001/c4.exr" in r.getMessage()]
    assert len(lines) == 1 and "3 NaN/Inf/negative" in lines[0]


def test_missing_buffer_and_unknown_buffer(tmp_path):
    store = _store(tmp_path, "data.segments=1", "data.frames_per_segment=2")
    with pytest.raises(ValueError, match="unknown buffer"):
        store.ensure({"c3"})
    store.ensure({"c1"}, progress=False)
    with pytest.raises(FileNotFoundError, match="python -m mcd.render"):
        store.load("cbox", 0, "albedo")


def test_odd_size_render_with_motion(tmp_path):
    store = _store(
        tmp_path, "data.width=17", "data.height=11", "data.segments=1", "data.frames_per_segment=3"
    )
    store.ensure({"c1", "motion"}, progress=False)
    assert store.load("cbox", 2, "c1").shape == (11, 17, 3)
    assert store.load("cbox", 2, "motion").shape == (11, 17, 2)
    assert not store.load("cbox", 0, "motion").any()  # frame 0 has no previous frame


def test_exposure_and_depth_scale_in_manifest(cbox_store):
    _, store = cbox_store
    man = store.manifest("cbox")
    assert man["exposure"] > 0 and man["depth_scale"] > 0
    ref0 = store.load("cbox", 0, "ref")
    assert abs(ref0.mean() - 0.5) < 1e-3  # exposure: auto brings frame 0's reference to data.exposure_target


def test_all_black_frames(tmp_path, monkeypatch, caplog):
    monkeypatch.setattr(SceneRenderer, "color", lambda self, spp, seed: np.zeros((32, 32, 3), np.float32))
    store = _store(tmp_path, "data.segments=1", "data.frames_per_segment=2")
    with caplog.at_level(logging.WARNING, logger="mcd.data.store"):
        store.ensure({"c4"}, progress=False)
    assert store.manifest("cbox")["exposure"] == 1.0 and any(
        "black" in r.getMessage() for r in caplog.records
    )
    assert not store.load("cbox", 1, "ref").any()


@pytest.mark.slow
def test_killed_render_process_resumes(tmp_path):
    """A real `python -m mcd.render` killed (SIGKILL) mid-run: the next ensure keeps its finished frames."""
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    base = [o for o in store32_overrides(tmp_path) if not o.startswith(("data.segments=", "data.ref_spp="))]
    args = [
        *base,
        "data.segments=1",
        "data.ref_spp=1024",
        "render.buffers=[c1]",
        f"hydra.run.dir={tmp_path}/h",
    ]
    env = {**os.environ, "PYTHONPATH": f"{repo}{os.pathsep}{os.environ.get('PYTHONPATH', '')}"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "mcd.render", *args],
        cwd=repo,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    manifest = tmp_path / "test32" / "cbox" / "manifest.json"
    deadline = time.time() + 120
    done: dict = {}
    while time.time() < deadline and proc.poll() is None:
        if manifest.is_file():
            done = json.loads(manifest.read_text())["files"]
            if len(done) >= 4:  # two frames (ref + c1) finished
                break
        time.sleep(0.05)
    assert proc.poll() is None, "the render finished before it could be interrupted"
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    done = json.loads(manifest.read_text())["files"]
    n_done = len({k.split("/")[0] for k in done if k.endswith("ref.exr")} & {k.split("/")[0] for k in done})
    assert 2 <= n_done < 6
    root = manifest.parent
    mtimes = {k: (root / k).stat().st_mtime_ns for k in done}
    resumed = StoreBuilder.from_cfg(compose_cfg(*args[:-1])).ensure({"c1"}, progress=False)
    assert resumed["reused"]["ref"] == len([k for k in done if k.endswith("ref.exr")])
    assert resumed["rendered"]["ref"] == 6 - resumed["reused"]["ref"]
    assert all((root / k).stat().st_mtime_ns == t for k, t in mtimes.items())
    assert not list(root.glob("*/.*.tmp*"))


def test_reader_without_overrides_spells_out_every_store_setting(tmp_path):
    """The render command printed in a store's errors, when no command line is known, reproduces the data
    settings that shape the store, the reference-quality ones included (docs/data.md "Reference quality")."""
    from mcd.data.store import StoreReader

    changed = ["data.ref_quality.target_db=35", "data.ref_quality.max_spp=2048", "data.exposure_target=0.25",
               "data.ref_spp=64", "data.max_depth=null", "data.test_scenes=[cbox]"]
    cfg = compose_cfg("data=tiny", f"paths.data_dir={tmp_path}", *changed)
    reader = StoreReader(cfg.paths.data_dir, cfg.data, None, overrides=None)
    command = shlex.split(reader.render_command())
    assert command[:3] == ["python", "-m", "mcd.render"]
    again = compose_cfg("data=tiny", *command[3:])
    for key in ("width", "height", "segments", "frames_per_segment", "ref_spp", "ref_quality", "gbuffer_spp",
                "max_depth", "seed", "exposure_target", "train_scenes", "transfer_scenes", "test_scenes"):
        assert again.data[key] == cfg.data[key], key
    assert again.paths.data_dir == str(tmp_path)

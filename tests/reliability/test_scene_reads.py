"""Campaign 9 (docs/reliability.md): a store renders a scene again when a file the scene reads changed.

The manifest keyed every render by the SHA-256 of the scene's XML file alone, though its docstring promised
that a change of what the scene is made of invalidates renders: with a mesh of the Cornell box changed (its
large box at half the size), ``python -m mcd.render`` said "reused" and the store kept the old renders, which
runs then trained and were tested on (a fresh store gave other bytes). Now the scene's source records
``reads``, a digest of every file it reads (:func:`mcd.data.scenes.scene_reads`: meshes, textures, included
XML), and a change renders the scene again; a manifest from before the key is reused as it is, without a
write.
"""

from __future__ import annotations

import json
import shutil

import pytest

from mcd.data import StoreBuilder
from mcd.data.scenes import VENDORED_DIR
from tests.conftest import compose_cfg, store32_overrides


def _store(data_dir, scene, *overrides: str) -> StoreBuilder:
    lists = [f"data.train_scenes=[{scene}]", f"data.test_scenes=[{scene}]"]
    return StoreBuilder.from_cfg(compose_cfg(*store32_overrides(data_dir), *lists, *overrides))


def _halve(obj) -> None:
    lines = [" ".join(["v", *(str(float(x) * 0.5) for x in ln.split()[1:4])]) if ln.startswith("v ") else ln
             for ln in obj.read_text().splitlines()]
    obj.write_text("\n".join(lines) + "\n")


@pytest.mark.slow
def test_a_changed_mesh_renders_the_scene_again(tmp_path):
    shutil.copytree(VENDORED_DIR / "cbox", tmp_path / "boxm")
    scene = tmp_path / "boxm" / "scene.xml"
    store = _store(tmp_path / "data", scene)
    store.ensure({"ref"}, progress=False)
    frame0 = store.path("boxm", 0, "ref")
    before = frame0.read_bytes()
    _halve(tmp_path / "boxm" / "meshes" / "cbox_largebox.obj")
    again = _store(tmp_path / "data", scene)
    report = again.ensure({"ref"}, progress=False)
    assert report["rendered"].get("ref") == 12, report
    fresh = _store(tmp_path / "fresh", scene)
    fresh.ensure({"ref"}, progress=False)
    assert frame0.read_bytes() != before
    assert frame0.read_bytes() == fresh.path("boxm", 0, "ref").read_bytes()


def test_a_manifest_from_before_the_key_is_reused_without_a_write(cbox_store, tmp_path):
    cfg, shared = cbox_store
    shutil.copytree(shared.data_dir, tmp_path / "data")
    store = StoreBuilder.from_cfg(compose_cfg(*store32_overrides(tmp_path / "data")))
    path = store.manifest_path("cbox")
    man = json.loads(path.read_text())
    man["source"].pop("reads", None)
    man.pop("exposure_target", None)
    path.write_text(json.dumps(man))
    text, mtime = path.read_text(), path.stat().st_mtime_ns
    report = store.ensure({"ref", "c4"}, progress=False)
    assert not report["rendered"], report
    assert path.read_text() == text and path.stat().st_mtime_ns == mtime

"""Store damage that parses but breaks the schema (``"files": 5``, an entry without
``bytes``, a string exposure) and a ``.lock`` that is a directory gave tracebacks (AttributeError,
IsADirectoryError); each is now named with its file and the fix."""

from __future__ import annotations

import json
import re

import pytest
from omegaconf import open_dict

from mcd.data import StoreBuilder
from mcd.data.store import CorruptManifestError


@pytest.mark.parametrize(("damage", "problem"), [
    (lambda man: man.update(files=5), "'files' is 5, not an object of file entries"),
    (lambda man: man["files"]["0000/ref.exr"].pop("bytes"), "files['0000/ref.exr'] lacks an integer 'bytes'"),
    (lambda man: man["files"].update({"0001/c1.exr": [1]}), "files['0001/c1.exr'] is [1], not an object"),
    (lambda man: man.update(cameras={"a": 1}), "'cameras' is not a list of camera objects"),
    (lambda man: man.update(exposure="bright"), "'exposure' is 'bright', not a number"),
])
def test_a_manifest_that_breaks_the_schema_is_named_with_its_fix(own_store, damage, problem):
    cfg, store = own_store
    path = store.manifest_path("cbox")
    man = json.loads(path.read_text())
    damage(man)
    path.write_text(json.dumps(man))
    named = rf"{re.escape(str(path))}: not a store manifest \({re.escape(problem)}.*render\.verify=true"
    with pytest.raises(CorruptManifestError, match=named):
        StoreBuilder.from_cfg(cfg).load("cbox", 0, "ref")
    with pytest.raises(CorruptManifestError, match=named):
        StoreBuilder.from_cfg(cfg).ensure({"c1"}, progress=False)


@pytest.mark.slow
def test_following_the_fix_of_a_schema_break_repairs_the_store(own_store):
    cfg, store = own_store
    path = store.manifest_path("cbox")
    path.write_text(json.dumps({**json.loads(path.read_text()), "files": 5}))
    with open_dict(cfg):
        cfg.render.verify = True
    report = StoreBuilder.from_cfg(cfg).ensure({"c1"}, progress=False)
    assert report["rendered"] == {"ref": 12, "c1": 12}
    assert StoreBuilder.from_cfg(cfg).load("cbox", 0, "c1").shape == (32, 32, 3)


def test_a_lock_that_is_a_directory_is_named_with_its_fix(own_store):
    cfg, store = own_store
    lock = store.root / "cbox" / ".lock"
    lock.unlink(missing_ok=True)
    lock.mkdir()
    with pytest.raises(RuntimeError, match=rf"{re.escape(str(lock))}: the scene's lock file is not a regular "
                                           rf"file; remove it \(`rm -r {re.escape(str(lock))}`"):
        StoreBuilder.from_cfg(cfg).ensure({"c1"}, progress=False, scenes=["cbox"])

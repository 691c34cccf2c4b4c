"""Defects 19-21 of issue 48: the training store's own files (mcd/data/train_store.py, mcd/data/pack.py,
docs/training_store.md). Defect 19: a corrupt ``store.json`` or ``<scene>.json`` gave a JSONDecodeError or
KeyError traceback; it is named with its fix, and following the fix packs again. Real renders, real packs."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from mcd.data import BUFFERS
from mcd.data.pack import pack
from mcd.data.train_store import TrainStore, TrainStoreError, TrainStoreSettings
from tests.conftest import compose_cfg, store32_overrides


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
    assert message.startswith(f"{path} is corrupt (") and "python -m mcd.data.pack" in message, message
    if name == "store.json":  # what training opens, too
        with pytest.raises(TrainStoreError, match="is corrupt"):
            TrainStore.open(TrainStoreSettings.from_cfg(cfg), cfg.data, BUFFERS, "pack")
        assert f"delete {folder} and pack it again" in message
        shutil.rmtree(folder)
    else:
        assert "delete it and pack again" in message
        path.unlink()
    assert pack(cfg, store, BUFFERS)["packed"] == 10  # the fix, followed

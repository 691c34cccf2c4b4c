"""Campaign 8 (docs/reliability.md): a training store's ``store.json`` whose channel ranges are not the layout
the pack writes is refused. ``store.json`` was checked for its keys and types only: with the ranges of ``c4``
and ``ref`` (three channels each) swapped, the pack reused every frame (their CRC-32s intact), and clips read
the reference's channels as ``c4`` and the input's as ``ref``. Now ``meta_problem`` compares the ranges with
:func:`mcd.data.train_store.channel_ranges` of its buffers, and the store is named corrupt with its fix."""

from __future__ import annotations

import json

import pytest

from mcd.data import BUFFERS
from mcd.data.pack import pack
from mcd.data.train_store import TrainStore, TrainStoreError, TrainStoreSettings
from tests.conftest import compose_cfg, store32_overrides


def test_swapped_channel_ranges_are_named_not_read(cbox_store, tmp_path):
    _, store = cbox_store
    folder = tmp_path / "ts"
    cfg = compose_cfg(*store32_overrides(store.data_dir), "data.train_store.format=array",
                      f"data.train_store.dir={folder}")
    assert pack(cfg, store, BUFFERS)["packed"] == 10
    meta_path = folder / "store.json"
    meta = json.loads(meta_path.read_text())
    meta["channels"]["c4"], meta["channels"]["ref"] = meta["channels"]["ref"], meta["channels"]["c4"]
    meta_path.write_text(json.dumps(meta))
    with pytest.raises(TrainStoreError, match=rf"{meta_path} is corrupt \(channel ranges"):
        pack(cfg, store, BUFFERS)
    with pytest.raises(TrainStoreError, match="is corrupt"):
        TrainStore.open(TrainStoreSettings.from_cfg(cfg), cfg.data, BUFFERS, "pack")

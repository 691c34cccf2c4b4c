"""Campaign 10, part 1 (docs/reliability.md, "Campaign fixes"): a training store being trained from is not
packed over with other data.

Two configs of one profile whose EXR stores differ (another ``paths.data_dir``, ``data.seed`` or
``data.ref_spp``) and one ``data.train_store.dir``: while a run trained from the store (``mcd.run ...
data.train_store.format=array``, 1500 steps), ``python -m mcd.pack`` of the other config packed its 10
frames again in place ("packed 10 frame(s)", exit 0), and the run, whose frames are memory maps, read the
other store's frames from then on and finished, exit 0, without a word (high: a silent wrong result). Now an
open :class:`mcd.data.train_store.TrainStore` holds a shared lock on ``store.json`` and such a pack is refused
naming the store, the frames and the fixes; once the reader is gone it packs.
"""

from __future__ import annotations

import gc

import numpy as np
import pytest
from omegaconf import open_dict

from mcd.data import StoreBuilder
from mcd.data.pack import pack
from mcd.data.train_store import TrainStore, TrainStoreError, TrainStoreSettings
from tests.conftest import compose_cfg, store32_overrides

BUFFERS = ["c4", "ref"]


def _cfg(data_dir, train_store, *overrides: str):
    cfg = compose_cfg(*store32_overrides(data_dir), "data.train_store.format=array", *overrides)
    with open_dict(cfg):
        cfg.data.train_store.dir = str(train_store)
    return cfg


@pytest.mark.slow
def test_a_pack_of_other_data_into_a_store_being_trained_from_is_refused(cbox_store, tmp_path):
    shared = tmp_path / "train_store"
    cfg_a = _cfg(cbox_store[1].data_dir, shared)
    assert pack(cfg_a, StoreBuilder.from_cfg(cfg_a), BUFFERS)["packed"] == 10
    reading = TrainStore.open(TrainStoreSettings.from_cfg(cfg_a), cfg_a.data, BUFFERS, "pack a")
    before = reading.clip("cbox", [5], None)["ref"].numpy().copy()

    cfg_b = _cfg(tmp_path / "other", shared, "data.seed=1")
    other = StoreBuilder.from_cfg(cfg_b)
    other.ensure(set(BUFFERS), progress=False)
    with pytest.raises(TrainStoreError, match="is being trained from by another run") as err:
        pack(cfg_b, other, BUFFERS)
    assert "data.train_store.dir" in str(err.value) and "scene 'cbox'" in str(err.value)
    assert np.array_equal(reading.clip("cbox", [5], None)["ref"].numpy(), before)  # the run's frames kept

    del reading  # the run ended: the pack goes ahead, and the store holds the other data
    gc.collect()
    assert pack(cfg_b, other, BUFFERS)["packed"] == 10
    after = TrainStore.open(TrainStoreSettings.from_cfg(cfg_b), cfg_b.data, BUFFERS, "pack b")
    assert not np.array_equal(after.clip("cbox", [5], None)["ref"].numpy(), before)

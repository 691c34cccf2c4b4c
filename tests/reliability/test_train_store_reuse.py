"""A training store whose bytes are gone or damaged is packed again, never reused (mcd/data/pack.py,
docs/training_store.md "Pack: resumable, atomic, verified"): a deleted or truncated ``<scene>.npy`` came back
zero-filled and the pack said "reused 10" (training then ran at loss 0, validation 100 dB), and frames written
over in place were reused as they were. A recorded frame is now reused only if its bytes have the CRC-32
recorded when it was packed."""

from __future__ import annotations

import logging
import os

import numpy as np
import pytest

from mcd.data import BUFFERS
from mcd.data.pack import pack
from mcd.data.train_store import TrainStore, TrainStoreSettings
from tests.conftest import compose_cfg, store32_overrides


def _cfg(data_dir, folder):
    return compose_cfg(*store32_overrides(data_dir), "data.train_store.format=array",
                       "data.train_store.dtype=float16", f"data.train_store.dir={folder}")


def _damage(kind: str, cfg, path) -> set[int]:
    """Damage the packed scene file; return the packed frames (2..11) whose bytes it changed."""
    arr = np.load(path, mmap_mode="r+")
    offset, per_frame = arr.offset, arr[0].nbytes
    if kind == "deleted":
        del arr
        path.unlink()
        return set(range(2, 12))
    if kind == "truncated":
        del arr
        os.truncate(path, 1_000_000)
        return {f for f in range(2, 12) if offset + (f + 1) * per_frame > 1_000_000}
    ts = TrainStore.open(TrainStoreSettings.from_cfg(cfg), cfg.data, BUFFERS, "pack")
    c0, c1 = ts.ranges["ref"]
    arr[3, :, :, c0:c1] = 1000.0  # frame 3's ref channels written over in place, same size
    arr.flush()
    del arr
    return {3}


@pytest.mark.parametrize("kind", ["deleted", "truncated", "written_over"])
def test_a_store_whose_bytes_are_gone_or_damaged_is_packed_again(cbox_store, tmp_path, caplog, kind):
    _, store = cbox_store
    cfg = _cfg(store.data_dir, tmp_path / "ts")
    assert pack(cfg, store, BUFFERS)["packed"] == 10
    path = tmp_path / "ts" / "cbox.npy"
    clean = np.array(np.load(path, mmap_mode="r"))
    assert np.abs(clean[2:].astype(np.float32)).max() > 0
    changed = _damage(kind, cfg, path)
    assert changed and len(changed) < 10 or kind == "deleted"
    with caplog.at_level(logging.WARNING, logger="mcd.pack"):
        report = pack(cfg, store, BUFFERS)
    assert (report["packed"], report["reused"]) == (len(changed), 10 - len(changed))
    assert np.array_equal(np.load(path, mmap_mode="r"), clean)
    assert f"{path}: frame {max(changed)}'s bytes differ from those packed" in caplog.text
    assert pack(cfg, store, BUFFERS)["reused"] == 10  # repaired: reused from now on

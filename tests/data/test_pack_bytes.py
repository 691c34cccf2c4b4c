"""The pack writes each frame with ``os.pwrite``, one tile row at a time (mcd/data/pack.py,
docs/training_store.md "Pack: resumable, atomic, verified"); until commit 2401390 it tiled the whole frame and
wrote it through a memory map. The scene file it writes is byte for byte (SHA-256) the one of that former
path, kept here as the reference, and so are the CRC-32 and clamp counts it records: on a real 32x32 render
(one tile, padded) in float32 and in float16 with values clamped, and on a 203x141 store (4x3 tiles, the last
row and column padded) in both dtypes."""

from __future__ import annotations

import hashlib
import json
import shutil
import zlib
from pathlib import Path

import numpy as np
import pytest
from omegaconf import OmegaConf

from mcd.data import BUFFERS, StoreReader
from mcd.data.pack import frames_to_pack, pack
from mcd.data.synthetic_store import synthetic_data_cfg, write_synthetic_store
from mcd.data.train_store import FP16_MAX, TILE, channel_ranges, tile_grid
from tests.conftest import compose_cfg, store32_overrides


def _former_to_tiles(frame: np.ndarray) -> np.ndarray:
    """``mcd.data.train_store.to_tiles`` of commit 2401390: a ``(C, H, W)`` frame zero-padded, then tiled."""
    c, h, w = frame.shape
    ty, tx = tile_grid(h, w, TILE)
    padded = np.zeros((c, ty * TILE, tx * TILE), dtype=frame.dtype)
    padded[:, :h, :w] = frame
    return np.ascontiguousarray(padded.reshape(c, ty, TILE, tx, TILE).transpose(1, 3, 0, 2, 4))


def _former_pack(reader: StoreReader, cfg, scene: str, buffers: list[str], dtype: str, path: Path) -> dict:
    """The scene file as the pack of commit 2401390 wrote it (``open_memmap``, each frame assembled
    channel-first, clamped in float16, tiled and assigned through the map) at ``path``; returns ``{frame:
    (crc32, clamped)}`` as that pack recorded them."""
    ranges = channel_ranges(buffers)
    size = (int(cfg.data.height), int(cfg.data.width))
    n_channels = max(end for _, end in ranges.values())
    shape = (reader.frame_count(scene), *tile_grid(*size, TILE), n_channels, TILE, TILE)
    mm = np.lib.format.open_memmap(path, mode="w+", dtype=np.dtype(dtype), shape=shape)
    got = {}
    for f in frames_to_pack(reader, scene, cfg.data):
        frame = np.empty((n_channels, *size), dtype=np.float32)
        for b, (c0, c1) in ranges.items():
            frame[c0:c1] = reader.load(scene, f, b).transpose(2, 0, 1)
        clamped = 0
        if dtype == "float16":
            clamped = int((np.abs(frame) > FP16_MAX).sum())
            np.clip(frame, -FP16_MAX, FP16_MAX, out=frame)
        data = _former_to_tiles(frame.astype(np.float16) if dtype == "float16" else frame)
        mm[f] = data
        got[f] = (zlib.crc32(data.tobytes()), clamped)
    mm.flush()
    del mm
    return got


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _check_as_former(cfg, reader: StoreReader, scene: str, buffers: list[str], dtype: str, tmp_path: Path,
                     ) -> dict:
    """Pack with ``cfg`` and compare the scene's file and record with the former path's; returns the former
    path's ``{frame: (crc32, clamped)}``."""
    report = pack(cfg, reader, buffers)
    folder = Path(report["root"])
    former = _former_pack(reader, cfg, scene, buffers, dtype, tmp_path / "former.npy")
    assert report["packed"] == len(former) > 0
    assert _sha256(folder / f"{scene}.npy") == _sha256(tmp_path / "former.npy")
    record = json.loads((folder / f"{scene}.json").read_text())["frames"]
    assert {int(f): (e["crc32"], e["clamped"]) for f, e in record.items()} == former
    assert report["clamped"] == sum(c for _, c in former.values())
    return former


def test_a_real_render_packs_to_the_former_paths_bytes_in_float32(cbox_store, tmp_path):
    _, store = cbox_store
    cfg = compose_cfg(*store32_overrides(store.data_dir), "data.train_store.format=array",
                      f"data.train_store.dir={tmp_path / 'ts'}")
    _check_as_former(cfg, store, "cbox", list(BUFFERS), "float32", tmp_path)


def test_a_real_render_packs_to_the_former_paths_bytes_in_float16_with_values_clamped(cbox_store, tmp_path):
    _, store = cbox_store
    data_dir = tmp_path / "data"  # a copy whose exposure sends the colour far beyond 65504
    shutil.copytree(store.root, data_dir / "test32")
    man_path = data_dir / "test32" / "cbox" / "manifest.json"
    man_path.write_text(json.dumps({**json.loads(man_path.read_text()), "exposure": 1e6}))
    cfg = compose_cfg(*store32_overrides(data_dir), "data.train_store.format=array",
                      "data.train_store.dtype=float16")
    former = _check_as_former(cfg, StoreReader.from_cfg(cfg), "cbox", list(BUFFERS), "float16", tmp_path)
    assert sum(c for _, c in former.values()) > 1000


@pytest.mark.parametrize("dtype", ["float32", "float16"])
def test_an_odd_sized_store_of_several_tiles_packs_to_the_former_paths_bytes(tmp_path, dtype):
    data_cfg = synthetic_data_cfg("odd", "synth", 203, 141, 11)
    buffers = ["c1_in", "c4", "ref", "depth", "normal"]
    write_synthetic_store(tmp_path / "exr", data_cfg, buffers, seed=5)
    man_path = tmp_path / "exr" / "odd" / "synth" / "manifest.json"
    if dtype == "float16":  # colour beyond 65504 in some pixels: clamped across tile edges
        man_path.write_text(json.dumps({**json.loads(man_path.read_text()), "exposure": 2e5}))
    cfg = OmegaConf.create({"data": data_cfg, "paths": {"data_dir": str(tmp_path / "exr")}})
    cfg.data.train_store = {"format": "array", "dtype": dtype, "dir": str(tmp_path / "ts")}
    reader = StoreReader(tmp_path / "exr", cfg.data, overrides=[])
    former = _check_as_former(cfg, reader, "synth", buffers, dtype, tmp_path)
    assert len(former) == 10
    assert dtype == "float32" or sum(c for _, c in former.values()) > 0

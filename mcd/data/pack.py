"""Packing the EXR store's training and validation frames into the training store
(:mod:`mcd.data.train_store`, docs/training_store.md); the command is ``python -m mcd.pack`` (mcd/pack.py).

The unit of work is one frame of one scene: its buffers are read through
:meth:`mcd.data.store.StoreReader.load` (as models see them) and written into the scene's array one tile row
at a time (:func:`mcd.data.train_store.tile_row` into one reused buffer, ``os.pwrite``, read back and
compared, CRC-32 taken), flushed to disk, and only then recorded in the scene's pack record (written
atomically, :mod:`mcd.core.atomic_write`). Nothing is written through a memory map: its page faults and the
whole-frame temporaries were most of the pack's system time (docs/training_store.md, "Pack: resumable,
atomic, verified"). A pack killed at any point (kill -9 included) loses nothing: run again, it
skips recorded frames whose EXR sources are unchanged and whose bytes still have their recorded CRC-32 (a
deleted, truncated or overwritten file is packed again), and packs the rest. A store packed with another
config is refused before any work, naming the key (:func:`mcd.data.train_store.check_meta`); so is an EXR
store that lacks a file, naming the render command. One packer per scene at a time (``<scene>.lock``,
:func:`mcd.core.file_lock.exclusive`): a second one (another DDP rank) waits, then reuses the first one's
frames. A scene whose every frame is packed and intact is found so by reading alone and reused without the
lock, so a fully packed store on a read-only mount is trained from as it is.
"""

from __future__ import annotations

import logging
import os
import time
import zlib
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import DictConfig

from mcd.core import file_lock
from mcd.core.atomic_write import atomic_write, atomic_write_json, leftovers
from mcd.core.paths import free_space
from mcd.data.buffers import BUFFERS
from mcd.data.splits import split_of
from mcd.data.store import StoreReader
from mcd.data.store_builder import StoreBuilder
from mcd.data.train_store import (
    DTYPES,
    FP16_MAX,
    TILE,
    VERSION,
    TrainStore,
    TrainStoreError,
    TrainStoreSettings,
    channel_ranges,
    check_meta,
    frame_bytes,
    frame_digest,
    pack_command,
    read_meta,
    readers_elsewhere,
    tile_grid,
    tile_row,
)

log = logging.getLogger("mcd.pack")


def frames_to_pack(reader: StoreReader, scene: str, data_cfg: DictConfig) -> list[int]:
    """The frames of the scene's training and validation clips (what the datamodule reads from this store)."""
    sp = split_of(reader.frame_count(scene), data_cfg)
    return sorted({f for clip in sp["train"] + sp["val"] for f in clip})


def pack(cfg: DictConfig, reader: StoreReader, buffers: Iterable[str],
         scenes: Iterable[str] | None = None) -> dict[str, Any]:
    """Pack ``buffers`` of ``scenes`` (default ``data.train_scenes``) into the training store of ``cfg``
    (module docstring). Returns ``{"root", "packed", "reused", "clamped", "clamped_total", "seconds"}``
    (frames packed now, frames already packed, float16 values clamped now, and in every frame of ``scenes``
    the training reads, now or when it was packed). Everything that can be checked is checked before the
    first frame is read."""
    settings = TrainStoreSettings.from_cfg(cfg)
    buffers = [b for b in BUFFERS if b in set(buffers)]
    scenes = list(dict.fromkeys(scenes if scenes is not None else cfg.data.train_scenes))
    command = pack_command(reader.overrides, buffers)
    todo = {s: frames_to_pack(reader, s, cfg.data) for s in scenes}
    for scene, frames in todo.items():  # every source file listed, before any work
        files = reader.manifest(scene)["files"]
        absent = [(f, b) for f in frames for b in buffers if f"{f:04d}/{b}.exr" not in files]
        if absent:
            need = sorted({b for _, b in absent})
            raise FileNotFoundError(
                f"{reader.manifest_path(scene)}: {len(absent)} buffer file(s) to pack were never rendered "
                f"(e.g. frame {absent[0][0]} {absent[0][1]}); render them first: "
                f"{reader.render_command('render.buffers=[' + ','.join(need) + ']')}")
    if isinstance(reader, StoreBuilder):  # the EXR files are this config's renders (python -m mcd.pack)
        reader.check_rendered(todo, buffers)
    meta = {"version": VERSION, "dtype": settings.dtype, "tile": TILE, "width": int(cfg.data.width),
            "height": int(cfg.data.height), "profile": str(cfg.data.name),
            "channels": {b: list(r) for b, r in channel_ranges(buffers).items()}}
    meta_path = settings.dir / "store.json"
    check_unclaimed(settings.dir, meta_path, scenes)
    if meta_path.is_file():
        meta = read_meta(meta_path, command)
        check_meta(meta, settings, cfg.data, buffers, meta_path)
    store = TrainStore(settings.dir, meta, command)
    check_free_space(store, reader, todo)  # before the long work, not part-way
    if not meta_path.is_file():
        atomic_write_json(meta_path, meta)
    t0 = time.perf_counter()
    report = {"root": str(settings.dir), "packed": 0, "reused": 0, "clamped": 0}
    size = (int(cfg.data.height), int(cfg.data.width))
    for scene, frames in todo.items():
        if _packed_already(store, reader, scene, frames, size):  # read only: no lock, nothing written
            report["reused"] += len(frames)
            continue
        with file_lock.exclusive(settings.dir / f"{scene}.lock"):  # one packer per scene: others wait
            got = _pack_scene(store, reader, scene, frames, size)
        for k in ("packed", "reused", "clamped"):
            report[k] += got[k]
    report["clamped_total"] = sum(int(store.record(scene)["frames"].get(str(f), {}).get("clamped") or 0)
                                  for scene, frames in todo.items() for f in frames)
    report["seconds"] = time.perf_counter() - t0
    log.info("training store %s (%s): packed %d frame(s), reused %d, %d value(s) clamped to the float16 "
             "range, in %.1f s", settings.dir, settings.dtype, report["packed"], report["reused"],
             report["clamped"], report["seconds"])
    return report


def check_unclaimed(root: Path, meta_path: Path, scenes: Iterable[str]) -> None:
    """FileExistsError naming ``data.train_store.dir`` and the files where a folder without ``store.json``
    holds files named like the pack's own (``<scene>.npy``, ``<scene>.json``, ``<scene>.lock``): a folder of
    the user's, whose files the pack replaced (a ``cbox.npy`` of another shape was "packed again"). Checked
    before anything is written."""
    if meta_path.exists() or not root.is_dir():
        return
    clash = sorted(p.name for s in scenes for p in (root / f"{s}.npy", root / f"{s}.json", root / f"{s}.lock")
                   if p.exists() or p.is_symlink())
    if clash:
        raise FileExistsError(f"data.train_store.dir={root} holds {', '.join(clash)} and no store.json: it "
                              "is not a training store, and packing there would write over those files; give "
                              "data.train_store.dir a new or empty folder (or null, the default one)")


#: Room left on the store's disk beyond the frames themselves (the pack records, the store's own JSON).
SPACE_MARGIN = 1 << 20


def check_free_space(store: TrainStore, reader: StoreReader, todo: dict[str, list[int]]) -> None:
    """OSError naming ``data.train_store.dir``, the bytes needed and free, and what to do, when the disk of
    the store holds less free space than the frames of ``todo`` not yet recorded take (:func:`frame_bytes`
    each, plus :data:`SPACE_MARGIN`). Checked before the first byte is written, so that a pack that cannot
    finish says so before its long work (a write that fails all the same stops it naming the file and the
    frame, :func:`_write_checked`)."""
    n_channels = max(end for _, end in store.ranges.values())
    per_frame = frame_bytes(store.height, store.width, n_channels, store.dtype, store.tile)
    count = 0
    for scene, frames in todo.items():
        done = store.record(scene)["frames"] if store.scene_path(scene).is_file() else {}
        man = reader.manifest(scene)
        count += sum(done.get(str(f), {}).get("sources") != frame_digest(man, f, store.packed)
                     for f in frames)
    if not count:
        return
    need = count * per_frame + SPACE_MARGIN
    where, free = free_space(store.root)
    if free < need:
        raise OSError(f"data.train_store.dir={store.root}: packing {count} frame(s) needs "
                      f"{need / 1e6:.1f} MB and its disk ({where}) has {free / 1e6:.1f} MB free; free space "
                      "there, give a data.train_store.dir on a disk with room, or "
                      "data.train_store.dtype=float16 (half the bytes)")


def _scene_shape(store: TrainStore, reader: StoreReader, scene: str, size: tuple[int, int]) -> tuple:
    """The shape of the scene's array: frames, tile rows and columns, channels, tile, tile."""
    n_channels = max(end for _, end in store.ranges.values())
    return (reader.frame_count(scene), *tile_grid(*size, store.tile), n_channels, store.tile, store.tile)


def _packed_already(store: TrainStore, reader: StoreReader, scene: str, frames: list[int],
                    size: tuple[int, int]) -> bool:
    """Whether every one of ``frames`` is recorded as packed from the EXR files the manifest lists now and
    its bytes still have their CRC-32, found by reading alone: such a scene is reused without taking
    ``<scene>.lock`` or opening anything for writing, so a fully packed store on a read-only mount trains
    (a packer beside it only ever adds frames, each recorded after its bytes are written)."""
    path = store.scene_path(scene)
    if not path.is_file():
        return False
    done, man = store.record(scene)["frames"], reader.manifest(scene)
    if any(done.get(str(f), {}).get("sources") != frame_digest(man, f, store.packed) for f in frames):
        return False
    try:
        mm = np.load(path, mmap_mode="r")
    except (OSError, ValueError):  # truncated below its header's shape: _pack_scene packs it again
        return False
    if mm.shape != _scene_shape(store, reader, scene, size) or mm.dtype != store.dtype:
        return False
    chunk = bytearray(CHUNK)
    with open(path, "rb") as fh:
        return all(_bytes_intact(fh.fileno(), mm, f, done[str(f)].get("crc32"), chunk) for f in frames)


def _scene_array(store: TrainStore, reader: StoreReader, scene: str, size: tuple[int, int]) -> np.memmap:
    """The scene's ``.npy`` as an array over its file, for its shape and data offset (frames are written with
    ``os.pwrite``, :func:`_write_checked`, never through this map: a write through it faulted in every page);
    mapped ``r+`` so that a file truncated below its shape is extended back to it with zeros. Created (sparse,
    at a temp name, then renamed) when absent or shaped for another frame count (the EXR store was
    re-rendered with another sequence: every frame is packed again)."""
    path = store.scene_path(scene)
    shape = _scene_shape(store, reader, scene, size)
    if path.is_file():
        mm = np.load(path, mmap_mode="r+")
        if mm.shape == shape and mm.dtype == store.dtype:
            return mm
        log.warning("%s: shaped %s, the EXR store now gives %s: packing the scene again", path, mm.shape,
                    shape)
        del mm
        store.record_path(scene).unlink(missing_ok=True)
    atomic_write(path, lambda tmp: np.lib.format.open_memmap(tmp, mode="w+", dtype=store.dtype,
                                                             shape=shape).flush())
    return np.load(path, mmap_mode="r+")


def _pack_scene(store: TrainStore, reader: StoreReader, scene: str, frames: list[int],
                size: tuple[int, int]) -> dict[str, int]:
    """Pack the scene's ``frames`` that are missing or stale (module docstring: the unit of work)."""
    man = reader.manifest(scene)
    for stale in (*leftovers(store.scene_path(scene)), *leftovers(store.record_path(scene))):
        stale.unlink(missing_ok=True)  # of a killed packer; this one holds the scene's lock
    mm = _scene_array(store, reader, scene, size)
    record = store.record(scene)
    done = record["frames"]
    got = {"packed": 0, "reused": 0, "clamped": 0}
    fp16 = store.dtype == np.dtype(DTYPES["float16"])
    stale = [f for f in frames
             if str(f) in done and done[str(f)].get("sources") != frame_digest(man, f, store.packed)]
    if stale and readers_elsewhere(store.root):
        raise TrainStoreError(
            f"{store.root} is being trained from by another run (it holds store.json's lock), and this "
            f"config's EXR files differ from those {len(stale)} of scene {scene!r}'s packed frames were made "
            f"from (e.g. frame {stale[0]}): packing them now would change the frames that run reads. Give "
            "this config its own data.train_store.dir (or null, the default below its data folder), or pack "
            "after that run ends")
    path = store.scene_path(scene)
    row = np.empty(mm.shape[2:], dtype=np.float32)  # one tile row, reused for every row of every frame
    out = np.empty(mm.shape[2:], dtype=store.dtype) if fp16 else row
    back = np.empty(out.nbytes, dtype=np.uint8)
    chunk = bytearray(CHUNK)
    with open(path, "r+b") as fh:
        fd = fh.fileno()
        for f in frames:
            digest = frame_digest(man, f, store.packed)
            if done.get(str(f), {}).get("sources") == digest:
                if _bytes_intact(fd, mm, f, done[str(f)].get("crc32"), chunk):
                    got["reused"] += 1
                    continue
                log.warning("%s: frame %d's bytes differ from those packed (CRC-32; the file was deleted, "
                            "truncated or written over): packing it again", path, f)
            parts = []
            for b in store.packed:
                image = reader.load(scene, f, b)
                if image.shape != (*size, store.ranges[b][1] - store.ranges[b][0]):
                    raise ValueError(f"{reader.path(scene, f, b)}: {image.shape} (height, width, channels), "
                                     f"the store packs {size[1]}x{size[0]} frames of {b}: render it again")
                parts.append((store.ranges[b][0], image))
            start, _ = _frame_span(mm, f)
            crc = clamped = 0
            for ty in range(mm.shape[1]):
                tile_row(row, parts, ty)
                if fp16:
                    over = int(np.count_nonzero(np.abs(row) > FP16_MAX))
                    if over:
                        np.clip(row, -FP16_MAX, FP16_MAX, out=row)
                        clamped += over
                    out[...] = row
                _write_checked(fd, out, start + ty * out.nbytes, back, path, f)
                crc = zlib.crc32(out, crc)
            if clamped:
                log.warning("%s frame %d: %d value(s) beyond the float16 range clamped to +-%g "
                            "(data.train_store.dtype=float16; float32 keeps them)", scene, f, clamped,
                            FP16_MAX)
            os.fdatasync(fd)  # on disk before it is recorded
            done[str(f)] = {"sources": digest, "crc32": crc, "clamped": clamped}
            atomic_write_json(store.record_path(scene), record)
            got["packed"] += 1
            got["clamped"] += clamped
    return got


#: Bytes read at a time when a packed frame's CRC-32 is checked (one reused buffer, not the whole frame).
CHUNK = 1 << 20


def _frame_span(mm: np.memmap, frame: int) -> tuple[int, int]:
    """``(offset, bytes)``: where ``frame``'s packed bytes lie in the scene file whose array is ``mm``."""
    n = mm[0].nbytes
    return mm.offset + frame * n, n


def _write_checked(fd: int, data: np.ndarray, offset: int, back: np.ndarray, path: Path, frame: int) -> None:
    """Write ``data`` at ``offset`` of the open scene file ``fd``, read it back into ``back`` (as long) and
    compare: OSError naming the file and the frame when the write fails (a full disk: ENOSPC here, where a
    write through a memory map died of SIGBUS) or the file reads back other bytes."""
    rest, at = memoryview(data).cast("B"), offset
    try:
        while rest and (n := os.pwrite(fd, rest, at)):  # a short write (the disk filling): the rest again
            rest, at = rest[n:], at + n
    except OSError as err:
        raise OSError(err.errno, f"{path}: frame {frame} could not be written ({err.strerror}); nothing was "
                                 "recorded for it: free space there and pack again") from err
    if (rest or os.preadv(fd, [back], offset) != data.nbytes
            or not np.array_equal(back, data.reshape(-1).view(np.uint8))):
        raise OSError(f"{path}: frame {frame} reads back other bytes than were written (disk full or "
                      "failing?); nothing was recorded for it: pack again")


def _bytes_intact(fd: int, mm: np.memmap, frame: int, crc: Any, chunk: bytearray) -> bool:
    """Whether the packed bytes of ``frame`` in the open scene file ``fd`` (its array ``mm``) are whole and
    have the CRC-32 recorded when they were packed: a frame is reused only then, so a store whose file was
    deleted, truncated (opening its array zero-fills it again) or written over in place is packed again, never
    read as zeros or damage (docs/training_store.md, "Pack: resumable, atomic, verified"). Read ``chunk``'s
    length at a time into it."""
    if not isinstance(crc, int):
        return False
    offset, n = _frame_span(mm, frame)
    view, value, read = memoryview(chunk), 0, 0
    while read < n:
        got = os.preadv(fd, [view[: min(len(view), n - read)]], offset + read)
        if not got:  # the file ends inside the frame
            return False
        value = zlib.crc32(view[:got], value)
        read += got
    return value == crc

"""How fast one loader worker makes training clips, from the EXR store and from the training store
(docs/training_store.md). The core of ``python -m mcd.bench --loader`` and of the loader
line of ``mcd.plan``; it imports neither Lightning nor Hydra.

:func:`measure` writes a synthetic EXR store of the given shape in a folder (:mod:`mcd.data.synthetic_store`;
reused when a previous call left one of the same shape there), packs it into the training store with the real
pack (:func:`mcd.data.pack.pack`; a synthetic pack of another shape left there is packed again), then times,
each in its own forked process that does what one DataLoader worker does (read a clip at a random crop,
collate it):

- ``exr``: today's EXR path (:class:`mcd.data.clips.ExrClips`: whole-frame decodes, then the crop);
- ``array``, warm page cache: :meth:`mcd.data.train_store.TrainStore.clip` after the files were read once;
- ``array``, cold page cache: the same, with the scene's file evicted before every clip
  (``os.posix_fadvise(POSIX_FADV_DONTNEED)`` after ``fsync``, the memory map reopened), only the read timed;
- optionally ``zarr``: the same frames in a Zarr v3 array (Blosc LZ4 with byte shuffle, one chunk per frame
  and 128x128 tile, all channels), warm, for the comparison of designs (needs the ``zarr`` package).

Each figure says which bound it hits: ``disk`` where the worker fetched from storage (``read_bytes`` of
``/proc/self/io``, page faults of a memory map included) at least half the bytes its clips hold; else it is
CPU-bound, in ``decode`` (EXR, Zarr: decompression) or ``memory`` (the training store: copies out of the page
cache, no decode). ``cpu_fraction`` (CPU time over wall time) says how much of the wall time the worker got a
core: on a shared machine other processes take the rest; ``clips_per_cpu_s`` is the rate per second of CPU
the worker got, the figure that load does not change much. The EXR worker runs with glibc's default
allocator, as the datamodule's EXR workers do; the training store's and Zarr's keep freed memory, as the
datamodule's training-store workers do (:class:`mcd.data.train_store.TrainStore`). ``worker_rss_mb`` is the
worker's resident memory (``VmRSS``: private memory plus the pages of the store it has mapped;
``..._anon_mb`` the private part).
"""

from __future__ import annotations

import json
import logging
import multiprocessing as mp
import os
import random
import shutil
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import OmegaConf

from mcd.core.allocator import keep_freed_memory
from mcd.core.machine import status_mb
from mcd.data.clips import ExrClips
from mcd.data.pack import pack
from mcd.data.store import StoreReader
from mcd.data.synthetic_store import synthetic_data_cfg, write_synthetic_store
from mcd.data.train_store import TrainStore, TrainStoreError, TrainStoreSettings, check_meta, frame_bytes

log = logging.getLogger(__name__)

PROFILE, SCENE = "loaderbench", "synthetic"
#: bytes fetched from storage over the bytes of the clips, from which a figure counts as disk-bound
DISK_BOUND_READ = 0.5


def _read_bytes() -> int:
    """Bytes this process caused to be fetched from storage (``/proc/self/io``)."""
    for line in Path("/proc/self/io").read_text().splitlines():
        if line.startswith("read_bytes:"):
            return int(line.split()[1])
    return 0


def _timed_loop(read: Callable[[int], None], n_clips: int, seconds: float, min_clips: int,
                untimed: Callable[[], None] | None = None) -> dict[str, float]:
    """Call ``read(i)`` for clips until ``seconds`` have passed (at least ``min_clips``, at most ``n_clips``),
    ``untimed()`` before each, outside the timing; CPU and wall seconds of the reads, and the memory after."""
    wall = cpu = 0.0
    clips = disk = 0
    while clips < n_clips and (clips < min_clips or wall < seconds):
        if untimed is not None:
            untimed()
        c0, t0, d0 = time.process_time(), time.perf_counter(), _read_bytes()
        read(clips)
        wall += time.perf_counter() - t0
        cpu += time.process_time() - c0
        disk += _read_bytes() - d0
        clips += 1
    return {"clips": clips, "wall_s": wall, "cpu_s": cpu, "disk_bytes": disk, "rss_mb": status_mb("VmRSS"),
            "rss_anon_mb": status_mb("RssAnon")}


def _in_child(fn: Callable[..., dict], *args: Any) -> dict:
    """``fn(*args)`` in a forked process (one loader worker), its dict returned."""
    ctx = mp.get_context("fork")
    q = ctx.Queue()

    def target() -> None:
        import torch

        torch.set_num_threads(1)
        try:
            q.put(fn(*args))
        except BaseException as err:  # reported to the parent, which raises
            q.put({"error": f"{type(err).__name__}: {err}"})

    p = ctx.Process(target=target)
    p.start()
    out = q.get()
    p.join()
    if "error" in out:
        raise RuntimeError(f"loader measurement failed in its worker: {out['error']}")
    return out


def _crops(n: int, starts: Sequence[int], clip_len: int, size: tuple[int, int], crop: int,
           seed: int) -> list[tuple[list[int], tuple[int, int, int, int]]]:
    """``n`` random clips (frames, crop) over the packed frames."""
    rng = random.Random(seed)
    h, w = size
    return [(list(range(s, s + clip_len)), (rng.randint(0, h - crop), rng.randint(0, w - crop), crop, crop))
            for s in (rng.choice(starts) for _ in range(n))]


def _exr_worker(reader: StoreReader, buffers: list[str], clips: list, seconds: float) -> dict:
    from torch.utils.data import default_collate

    src = ExrClips(reader, buffers, cache=False)
    return _timed_loop(lambda i: default_collate([src.clip(SCENE, *clips[i])]), len(clips), seconds, 2)


def _array_worker(store: TrainStore, clips: list, seconds: float, cold: bool) -> dict:
    from torch.utils.data import default_collate

    keep_freed_memory()  # as a DataLoader worker of the training store does (TrainStore._map)

    path = store.scene_path(SCENE)

    def evict() -> None:
        store._maps.clear()  # a mapped page is not evicted: reopen the map after the eviction
        fd = os.open(path, os.O_RDONLY)
        try:
            os.fsync(fd)
            os.posix_fadvise(fd, 0, 0, os.POSIX_FADV_DONTNEED)
        finally:
            os.close(fd)

    read = lambda i: default_collate([store.clip(SCENE, *clips[i])])  # noqa: E731
    if not cold:
        for i in range(min(len(clips), 8)):  # warm the page cache and this process's page tables
            read(i)
    return _timed_loop(read, len(clips), seconds, 3, evict if cold else None)


def _zarr_worker(store: TrainStore, folder: Path, frames: list[int], clips: list, seconds: float) -> dict:
    """Write the packed frames into a Zarr v3 array (module docstring), then read clips from it, warm."""
    import zarr
    from torch.utils.data import default_collate

    keep_freed_memory()  # as for the training store: the comparison is of the designs

    channels = max(end for _, end in store.ranges.values())
    z = zarr.create_array(folder / "zarr" / f"{SCENE}.zarr", dtype=store.dtype, overwrite=True,
                          shape=(max(frames) + 1, channels, store.height, store.width),
                          chunks=(1, channels, 128, 128),
                          compressors=zarr.codecs.BloscCodec(cname="lz4", clevel=5, shuffle="shuffle"))
    for f in frames:
        whole = store.clip(SCENE, [f], None)
        z[f] = np.concatenate([whole[b][0].numpy() for b in store.buffers]).astype(store.dtype)

    def read(i: int) -> None:
        fr, (y, x, h, w) = clips[i]
        a = z[fr[0] : fr[-1] + 1, :, y : y + h, x : x + w].astype(np.float32, copy=False)
        default_collate([{b: a[:, c0:c1] for b, (c0, c1) in store.ranges.items()}])

    for i in range(min(len(clips), 4)):
        read(i)
    out = _timed_loop(read, len(clips), seconds, 3)
    out["bytes"] = sum(p.stat().st_size for p in (folder / "zarr").rglob("*") if p.is_file())
    return out


def _bound(r: dict, clip_bytes: float, cpu_bound: str) -> str:
    """``disk`` if the worker fetched at least :data:`DISK_BOUND_READ` of its clips' bytes from storage."""
    return "disk" if r["disk_bytes"] >= DISK_BOUND_READ * clip_bytes * r["clips"] else cpu_bound


def measure(folder: Path | str, buffers: Sequence[str], *, width: int = 1920, height: int = 1080,
            frames: int = 11, crop: int = 256, clip_len: int = 5, dtype: str = "float32",
            seconds: float = 5.0, zarr: bool = False, seed: int = 0) -> dict[str, Any]:
    """Clips/s of one loader worker at these shapes, EXR path and training store, in this one run (module
    docstring). ``folder`` holds the synthetic stores (about ``frames x channels x height x width x 4`` bytes
    twice; kept for the next call). ``seconds``: time per figure (the EXR path reads at least 2 clips, the
    others 3). Returns one flat dict of figures (``clips_per_s``, ``exr_clips_per_s``, ``cold_clips_per_s``,
    ``speedup``, ``worker_rss_mb``, ``bound``: the bound of each figure, ...)."""
    folder = Path(folder)
    if crop > min(width, height):
        raise ValueError(f"crop={crop} is larger than the {width}x{height} frames: give crop <= "
                         f"{min(width, height)}")
    if frames < clip_len + 1:
        raise ValueError(f"frames={frames}: need one test frame and one clip of {clip_len} (frames >= "
                         f"{clip_len + 1})")
    data_cfg = synthetic_data_cfg(PROFILE, SCENE, width, height, frames, clip_len)
    data_cfg.train_crop = data_cfg.val_crop = crop
    data_cfg.train_store = {"format": "array", "dtype": dtype, "dir": str(folder / f"train_{dtype}")}
    cfg = OmegaConf.create({"data": data_cfg, "paths": {"data_dir": str(folder / "exr")}})
    buffers = list(buffers)
    _drop_other_pack(TrainStoreSettings.from_cfg(cfg), data_cfg, buffers)
    t0 = time.perf_counter()
    if not _store_ready(folder / "exr", data_cfg, buffers):
        write_synthetic_store(folder / "exr", data_cfg, buffers, seed)
    write_s = time.perf_counter() - t0
    reader = StoreReader(folder / "exr", data_cfg, overrides=[])
    packed = pack(cfg, reader, buffers)
    store = TrainStore.open(TrainStoreSettings.from_cfg(cfg), data_cfg, buffers, "")
    starts = list(range(1, frames - clip_len + 1))
    clips = _crops(4096, starts, clip_len, (height, width), crop, seed)
    exr = _in_child(_exr_worker, reader, buffers, clips, seconds)
    warm = _in_child(_array_worker, store, clips, seconds, False)
    cold = _in_child(_array_worker, store, clips[::-1], seconds, True)
    channels = max(end for _, end in store.ranges.values())
    clip_bytes = clip_len * channels * crop * crop * store.dtype.itemsize
    packed_bytes = frame_bytes(height, width, channels, store.dtype, store.tile)
    out: dict[str, Any] = {
        "clips_per_s": warm["clips"] / warm["wall_s"],
        "exr_clips_per_s": exr["clips"] / exr["wall_s"],
        "cold_clips_per_s": cold["clips"] / cold["wall_s"],
        "worker_rss_mb": warm["rss_mb"],
        "worker_rss_anon_mb": warm["rss_anon_mb"],
        "exr_worker_rss_mb": exr["rss_mb"],
        "cold_worker_rss_mb": cold["rss_mb"],
        "bound": {"clips_per_s": _bound(warm, clip_bytes, "memory"),
                  "cold_clips_per_s": _bound(cold, clip_bytes, "memory"),
                  "exr_clips_per_s": _bound(exr, clip_bytes, "decode")},
        "disk_mb_per_clip": {k: r["disk_bytes"] / r["clips"] / 2**20
                             for k, r in (("clips_per_s", warm), ("cold_clips_per_s", cold),
                                          ("exr_clips_per_s", exr))},
        "cpu_fraction": {"clips_per_s": warm["cpu_s"] / warm["wall_s"],
                         "cold_clips_per_s": cold["cpu_s"] / cold["wall_s"],
                         "exr_clips_per_s": exr["cpu_s"] / exr["wall_s"]},
        "clips_timed": {"clips_per_s": warm["clips"], "cold_clips_per_s": cold["clips"],
                        "exr_clips_per_s": exr["clips"]},
        "crop_mb_per_clip": clip_bytes / 2**20,
        "store_mb_per_frame": packed_bytes / 2**20,
        "exr_mb_per_frame": sum(r["bytes"] for k, r in reader.manifest(SCENE)["files"].items()
                                if k.startswith("0001/")) / 2**20,
        "pack_s_per_frame": packed["seconds"] / max(packed["packed"], 1) if packed["packed"] else None,
        "synthetic_write_s": write_s,
        "shape": {"width": width, "height": height, "frames": frames, "crop": crop, "clip_len": clip_len,
                  "buffers": buffers, "channels": channels, "dtype": dtype},
        "seconds": seconds,
    }
    out["speedup"] = out["clips_per_s"] / out["exr_clips_per_s"]
    out["clips_per_cpu_s"] = {"clips_per_s": warm["clips"] / warm["cpu_s"],
                              "cold_clips_per_s": cold["clips"] / cold["cpu_s"],
                              "exr_clips_per_s": exr["clips"] / exr["cpu_s"]}
    if zarr:
        z = _in_child(_zarr_worker, store, folder, list(range(1, frames)), clips, seconds)
        out["zarr_clips_per_s"] = z["clips"] / z["wall_s"]
        out["zarr_worker_rss_mb"] = z["rss_mb"]
        out["zarr_mb_per_frame"] = z["bytes"] / (frames - 1) / 2**20
        out["bound"]["zarr_clips_per_s"] = _bound(z, clip_bytes, "decode")
        out["cpu_fraction"]["zarr_clips_per_s"] = z["cpu_s"] / z["wall_s"]
        out["clips_per_cpu_s"]["zarr_clips_per_s"] = z["clips"] / z["cpu_s"]
    return out


def _drop_other_pack(settings: TrainStoreSettings, data_cfg: Any, buffers: list[str]) -> None:
    """Remove the synthetic training store a previous call left at ``settings.dir`` where it was packed at
    another frame size or without one of ``buffers`` (its ``store.json`` names :data:`PROFILE`), with a
    warning: the pack would refuse it after the EXR store was written again. A folder of another profile
    there is not this module's, and is left for the pack to name."""
    path = settings.dir / "store.json"
    try:
        meta = json.loads(path.read_text())
    except (OSError, ValueError):
        return
    if not isinstance(meta, dict) or meta.get("profile") != PROFILE:
        return
    try:
        check_meta(meta, settings, data_cfg, buffers, path)
    except (TrainStoreError, KeyError) as err:
        log.warning("the synthetic training store %s is of another shape (%s): packing it again",
                    settings.dir, err)
        shutil.rmtree(settings.dir)


def _store_ready(data_dir: Path, data_cfg: Any, buffers: list[str]) -> bool:
    """Whether ``data_dir`` already holds this synthetic store (same frames, size and buffers, files in
    place)."""
    man_path = data_dir / PROFILE / SCENE / "manifest.json"
    if not man_path.is_file():
        return False
    man = json.loads(man_path.read_text())
    n = int(data_cfg.frames_per_segment)
    cams = man.get("cameras") or []
    if len(cams) != n or cams[0]["width"] != int(data_cfg.width) or cams[0]["height"] != int(data_cfg.height):
        return False
    root = data_dir / PROFILE / SCENE
    return all((root / k).is_file() and (root / k).stat().st_size == man["files"].get(k, {}).get("bytes")
               for k in (f"{f:04d}/{b}.exr" for f in range(n) for b in buffers))

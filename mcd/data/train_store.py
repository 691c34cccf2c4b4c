"""The training store: the EXR store's training and validation frames packed into one memory-mapped,
channel-first array per scene, from which a crop of a clip reads only the bytes it covers
(docs/training_store.md; issue 30, part 1).

Why: a training clip of row F reads 12 buffers x 5 frames; from EXR each is a whole-frame decode (about 30 ms
at 1920x1080) to keep a 256x256 crop. Here a crop is ``clip_len x channels x crop`` row reads of ``crop``
values from the page cache or disk, no decode. The design (a numpy ``.npy`` memory map, as Intel Open Image
Denoise's training toolkit preprocesses EXR into one uncompressed tensor file per dataset) was chosen over a
chunked, compressed Zarr v3 store by the figures of ``python -m mcd.bench --loader`` (docs/training_store.md).

Layout (``data.train_store.dir``, default ``<paths.data_dir>/<data.name>/.train_<dtype>/``):

- ``store.json``: what the store was packed with (``dtype``, ``width``, ``height``, ``profile``, the
  ``buffers`` and their channel ranges). A config that differs is refused, naming the key
  (:meth:`TrainStore.open`).
- ``<scene>.npy``: shape ``(frames, channels, height, width)``, frame index = the EXR store's frame number,
  channels = the packed buffers' channels one after another in :data:`mcd.data.buffers.BUFFERS` order. Only
  training and validation frames are written; test frames stay holes of the sparse file (tests read EXR).
- ``<scene>.json``: per packed frame, the digest of the EXR files it was made from (their manifest SHA-256,
  the scene's exposure and depth scale), the CRC-32 of its bytes, and (float16) how many values were clamped.
  A frame counts as packed only once this record names it (written atomically after the frame's bytes are
  flushed and verified); one whose EXR sources changed since is stale. :mod:`mcd.data.pack` writes both files.

Values are those :meth:`mcd.data.store.StoreReader.load` gives (exposure applied, depth scaled, sanitised), so
the loader does no arithmetic and, in the lossless ``float32`` mode, a crop read here is bit-identical to the
crop of the EXR path. ``float16`` halves the bytes; values beyond its range (``|x| > 65504``) are clamped to
``+-65504`` and counted at pack time (never an Inf), and a read converts back to float32.

Memory maps are opened lazily on first read in the process that reads (a DataLoader worker), never pickled
open: :class:`TrainStore` pickles its paths and settings only.
"""

from __future__ import annotations

import hashlib
import json
import shlex
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Self

import numpy as np
import torch
from omegaconf import DictConfig

from mcd.data.buffers import BUFFERS, CHANNELS

#: ``store.json``'s format; a store of another version is refused (pack it again)
VERSION = 1
FORMATS = ("exr", "array")
DTYPES: dict[str, type[np.floating]] = {"float32": np.float32, "float16": np.float16}
#: the largest finite float16 (values beyond it are clamped when packing in float16)
FP16_MAX = float(np.finfo(np.float16).max)


class TrainStoreError(RuntimeError):
    """The training store is missing, stale or was packed with another config; the message names the key or
    the command that fixes it."""


@dataclass(frozen=True)
class TrainStoreSettings:
    """``data.train_store.*``: ``format`` (``exr``: training reads the EXR store; ``array``: this store),
    ``dtype`` (``float32`` lossless, ``float16``) and ``dir`` (the store's folder)."""

    format: str
    dtype: str
    dir: Path

    @classmethod
    def from_cfg(cls, cfg: DictConfig) -> Self:
        """The settings of a full config; ValueError naming the key for an unknown format or dtype. A config
        without ``data.train_store`` reads EXR (the behaviour before the key existed)."""
        ts = cfg.data.get("train_store") or {}
        fmt, dtype = str(ts.get("format", "exr")), str(ts.get("dtype", "float32"))
        if fmt not in FORMATS:
            raise ValueError(f"data.train_store.format={fmt!r}: give one of {list(FORMATS)} "
                             "(docs/training_store.md)")
        if dtype not in DTYPES:
            raise ValueError(f"data.train_store.dtype={dtype!r}: give one of {list(DTYPES)} "
                             "(docs/training_store.md)")
        folder = ts.get("dir")
        root = Path(folder) if folder else Path(cfg.paths.data_dir) / str(cfg.data.name) / f".train_{dtype}"
        return cls(fmt, dtype, root)


def channel_ranges(buffers: Iterable[str]) -> dict[str, tuple[int, int]]:
    """``{buffer: (first, end)}``: where each buffer's channels lie in a frame, in table order."""
    out, c = {}, 0
    for b in (b for b in BUFFERS if b in set(buffers)):
        out[b] = (c, c + CHANNELS[b])
        c += CHANNELS[b]
    return out


def frame_digest(manifest: dict, frame: int, buffers: Iterable[str]) -> str:
    """The digest of the EXR files a packed frame is made of: their manifest SHA-256, and the scene's exposure
    and depth scale (which :meth:`StoreReader.load` applies). It changes when any of them is re-rendered."""
    files = manifest["files"]
    parts = [f"{b}:{files.get(f'{frame:04d}/{b}.exr', {}).get('sha256')}" for b in buffers]
    parts += [f"exposure:{manifest.get('exposure')!r}", f"depth_scale:{manifest.get('depth_scale')!r}"]
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


class TrainStore:
    """Reads crops of clips from a packed training store (module docstring). Made by :meth:`open`."""

    def __init__(self, root: Path, meta: dict, pack_command: str, buffers: Iterable[str] | None = None):
        """``meta``: the store's ``store.json``; ``buffers``: those :meth:`clip` reads (default: every packed
        one)."""
        self.root, self.meta, self.pack_command = Path(root), meta, pack_command
        self.dtype = np.dtype(meta["dtype"])
        self.ranges = {b: (int(r[0]), int(r[1])) for b, r in meta["channels"].items()}
        #: the packed buffers (a frame's channels), and those a clip reads
        self.packed: list[str] = list(self.ranges)
        self.buffers: list[str] = [b for b in self.packed if buffers is None or b in set(buffers)]
        self._maps: dict[str, np.memmap] = {}

    # ------------------------------------------------------------------------------------------- opening
    @classmethod
    def open(cls, settings: TrainStoreSettings, data_cfg: DictConfig, buffers: Iterable[str],
             pack_command: str) -> Self:
        """The store at ``settings.dir``, checked against the config: TrainStoreError naming the key whose
        value differs from the one it was packed with (``data.train_store.dtype``, ``data.width``,
        ``data.height``, ``data.name``), or naming the buffers it lacks, or ``pack_command`` if it was never
        packed."""
        path = settings.dir / "store.json"
        if not path.is_file():
            raise TrainStoreError(f"{settings.dir}: no training store (data.train_store.format=array); pack "
                                  f"it first: {pack_command}")
        meta = json.loads(path.read_text())
        check_meta(meta, settings, data_cfg, buffers, path)
        return cls(settings.dir, meta, pack_command, buffers)

    def scene_path(self, scene: str) -> Path:
        return self.root / f"{scene}.npy"

    def record_path(self, scene: str) -> Path:
        return self.root / f"{scene}.json"

    def record(self, scene: str) -> dict:
        """The scene's pack record (``{"frames": {...}}``; empty if nothing was packed)."""
        p = self.record_path(scene)
        return json.loads(p.read_text()) if p.is_file() else {"frames": {}}

    def check_frames(self, scene: str, frames: Iterable[int], manifest: dict) -> None:
        """TrainStoreError naming the pack command unless every frame is packed from the EXR files the
        manifest lists now (a frame whose EXR was re-rendered since is stale)."""
        done = self.record(scene)["frames"]
        frames = sorted(set(frames))
        missing = [f for f in frames if str(f) not in done]
        stale = [f for f in frames if str(f) in done
                 and done[str(f)]["sources"] != frame_digest(manifest, f, self.packed)]
        if missing or stale:
            raise TrainStoreError(
                f"{self.scene_path(scene)}: {len(missing)} frame(s) not packed (e.g. {missing[:3]}) and "
                f"{len(stale)} packed from EXR files re-rendered since (e.g. {stale[:3]}) of scene "
                f"{scene!r}; pack them: {self.pack_command}")

    # ------------------------------------------------------------------------------------------- reading
    def _map(self, scene: str) -> np.memmap:
        """The scene's array, memory-mapped read-only on first use in this process."""
        if scene not in self._maps:
            self._maps[scene] = np.load(self.scene_path(scene), mmap_mode="r")
        return self._maps[scene]

    def clip(self, scene: str, frames: list[int], crop: tuple[int, int, int, int] | None) -> dict[str, Any]:
        """``{buffer: float32 tensor [T, C, h, w], "scene": scene, "frame": LongTensor[T]}`` for the crop
        ``(y, x, h, w)`` (None: the whole frame) of ``frames``: what the EXR path's clip gives (the
        datamodule's contract, docs/architecture.md "Batches"). Reads only the rows the crop covers."""
        mm = self._map(scene)
        _, _, height, width = mm.shape
        y, x, h, w = crop if crop is not None else (0, 0, height, width)
        if y < 0 or x < 0 or y + h > height or x + w > width:
            raise ValueError(f"crop {(y, x, h, w)} (y, x, h, w) lies outside the {width}x{height} frames of "
                             f"{self.scene_path(scene)}")
        out: dict[str, Any] = {}
        for b in self.buffers:
            c0, c1 = self.ranges[b]
            dst = np.empty((len(frames), c1 - c0, h, w), dtype=np.float32)
            for t, f in enumerate(frames):
                np.copyto(dst[t], mm[f, c0:c1, y : y + h, x : x + w], casting="same_kind")
            out[b] = torch.from_numpy(dst)
        out["scene"] = scene
        out["frame"] = torch.tensor(frames, dtype=torch.long)
        return out

    def __getstate__(self) -> dict:
        """Pickled without its memory maps: a DataLoader worker opens its own on first read."""
        return {**self.__dict__, "_maps": {}}


def check_meta(meta: dict, settings: TrainStoreSettings, data_cfg: DictConfig, buffers: Iterable[str],
               path: Path) -> None:
    """TrainStoreError unless the store described by ``meta`` (its ``store.json`` at ``path``) was packed with
    this config's dtype, frame size and profile and holds every buffer in ``buffers``. The message names the
    key and both values, and what to do."""
    if meta.get("version") != VERSION:
        raise TrainStoreError(f"{path}: a training store of format version {meta.get('version')!r}, this mcd "
                              f"reads version {VERSION}; delete {path.parent} and pack it again")
    mine = {"data.train_store.dtype": settings.dtype, "data.width": int(data_cfg.width),
            "data.height": int(data_cfg.height), "data.name": str(data_cfg.name)}
    theirs = {"data.train_store.dtype": meta["dtype"], "data.width": meta["width"],
              "data.height": meta["height"], "data.name": meta["profile"]}
    for key, value in mine.items():
        if theirs[key] != value:
            raise TrainStoreError(
                f"{key}={value}: the training store {path.parent} was packed with {key}={theirs[key]}; give "
                f"another data.train_store.dir (or the default one: data.train_store.dir=null), or delete "
                f"{path.parent} and pack it again")
    lacking = sorted(set(buffers) - set(meta["channels"]))
    if lacking:
        raise TrainStoreError(
            f"the training store {path.parent} holds buffers {list(meta['channels'])}, this run also reads "
            f"{lacking}; give another data.train_store.dir, or delete {path.parent} and pack it again with "
            "every buffer (render.buffers=all)")


def pack_command(overrides: Iterable[str], buffers: Iterable[str]) -> str:
    """The ``python -m mcd.data.pack`` command that packs ``buffers`` with a store's overrides."""
    listed = ",".join(b for b in BUFFERS if b in set(buffers))
    return shlex.join(["python", "-m", "mcd.data.pack", *overrides, f"render.buffers=[{listed}]"])

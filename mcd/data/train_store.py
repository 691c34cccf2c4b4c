"""The training store: the EXR store's training and validation frames packed into one memory-mapped,
channel-first array per scene, from which a crop of a clip reads only the bytes it covers
(docs/training_store.md).

Why: a training clip of row F reads 12 buffers x 5 frames; from EXR each is a whole-frame 1920x1080 decode
to keep a 256x256 crop (docs/training_store.md measures what that costs). Here a crop is ``clip_len x
channels x crop`` row reads of ``crop`` values from the page cache or disk, no decode. The design (a numpy
``.npy`` memory map, as Intel Open Image Denoise's training toolkit preprocesses EXR into one uncompressed
tensor file per dataset) was chosen over a chunked, compressed Zarr v3 store by the figures of ``python -m
mcd.bench --loader`` (docs/training_store.md).

Layout (``data.train_store.dir``, default ``<paths.data_dir>/<data.name>/.train_<dtype>/``):

- ``store.json``: what the store was packed with (``dtype``, ``width``, ``height``, ``profile``, the
  ``buffers`` and their channel ranges). A config that differs is refused, naming the key
  (:meth:`TrainStore.open`).
- ``<scene>.npy``: shape ``(frames, tiles_y, tiles_x, channels, tile, tile)``: each frame cut into square
  tiles of :data:`TILE` pixels (the last row and column of tiles padded with zeros), each tile holding every
  channel, channel-first; frame index = the EXR store's frame number; channels = the packed buffers' channels
  one after another in :data:`mcd.data.buffers.BUFFERS` order. A crop of a clip is then, per frame, one
  contiguous run of tiles per tile row (a 256x256 crop: 5 runs of about 2.5 MB for row F's 31 channels), so a
  cold read fetches about 1.6 times the crop's bytes instead of whole image rows. Only training and
  validation frames are written; test frames stay holes of the sparse file (tests read EXR).
- ``<scene>.json``: per packed frame, the digest of the EXR files it was made from (their manifest SHA-256,
  the scene's exposure and depth scale), the CRC-32 of its bytes, and (float16) how many values were clamped.
  A frame counts as packed only once this record names it (written atomically after the frame's bytes are
  flushed and verified); one whose EXR sources changed since is stale. :mod:`mcd.data.pack` writes both files.

Values are those :meth:`mcd.data.store.StoreReader.load` gives (exposure applied, depth scaled, sanitised), so
the loader does no arithmetic and, in the lossless ``float32`` mode, a crop read here is bit-identical to the
crop of the EXR path. ``float16`` halves the bytes; values beyond its range (``|x| > 65504``) are clamped to
``+-65504`` and counted at pack time (never an Inf), and a read converts back to float32.

A store being trained from is held: :meth:`TrainStore.open` (the datamodule's) takes a shared ``flock`` on
``store.json`` for the life of the object (its loader workers inherit it), and a pack that would write over a
frame packed from other EXR files refuses while any reader holds it (:func:`readers_elsewhere`,
:mod:`mcd.data.pack`): the frames are memory-mapped, so a run beside such a pack read the other store's
frames from then on without a word.

Memory maps are opened lazily on first read in the process that reads (a DataLoader worker), never pickled
open: :class:`TrainStore` pickles its paths and settings only. A loader worker that opens one also has glibc
keep freed memory (:func:`mcd.core.allocator.keep_freed_memory`): a clip's arrays then reuse the pages the
last clip freed instead of faulting in fresh zeroed ones, which nearly doubled the clips per CPU second
(docs/training_store.md).
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import mmap
import shlex
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, BinaryIO, Self

import numpy as np
import numpy.typing as npt
import torch
from omegaconf import DictConfig

from mcd.core.allocator import keep_freed_memory
from mcd.core.paths import data_dir as resolve_data_dir
from mcd.core.paths import folder_to_be
from mcd.data.buffers import BUFFERS, CHANNELS

#: ``store.json``'s format; a store of another version is refused (pack it again)
VERSION = 2
FORMATS = ("exr", "array")
DTYPES: dict[str, type[np.floating]] = {"float32": np.float32, "float16": np.float16}
#: the largest finite float16 (values beyond it are clamped when packing in float16)
FP16_MAX = float(np.finfo(np.float16).max)
#: the ``.npy`` header readers by format version (``np.lib.format.open_memmap`` writes 1.0, or 2.0 for a
#: very long header)
_NPY_HEADERS = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
#: tile side in pixels (docs/training_store.md, "Layout": the tile size against the bytes a crop reads)
TILE = 64


def tile_grid(height: int, width: int, tile: int = TILE) -> tuple[int, int]:
    """``(tiles_y, tiles_x)``: the ``ceil(H / tile) x ceil(W / tile)`` tiles a frame is cut into, the last row
    and column padded with zeros (docs/training_store.md, "Layout")."""
    return -(-height // tile), -(-width // tile)


def frame_bytes(height: int, width: int, channels: int, dtype: npt.DTypeLike, tile: int = TILE) -> int:
    """Bytes one packed frame takes in its scene's array: its :func:`tile_grid` of ``channels x tile x tile``
    values of ``dtype``, the padding included (docs/training_store.md, "Layout"; ``python -m mcd.plan`` counts
    the store with it)."""
    tiles_y, tiles_x = tile_grid(height, width, tile)
    return tiles_y * tiles_x * channels * tile * tile * np.dtype(dtype).itemsize


def tile_row(out: np.ndarray, parts: Iterable[tuple[int, np.ndarray]], row: int) -> np.ndarray:
    """Tile row ``row`` of a frame, written into ``out`` (``(tiles_x, channels, tile, tile)``) and returned:
    each ``(first, image)`` of ``parts`` is an ``(H, W, c)`` image of the frame whose channels go to
    ``first:first + c`` (together they fill every channel), and the padding beyond the frame's last row and
    column is zero (docs/training_store.md, "Layout"). A packed frame is its :func:`tile_grid` rows one after
    another, each one contiguous run of the scene's array, so the pack writes a frame row by row through one
    reused buffer."""
    parts = list(parts)
    h, w, _ = parts[0][1].shape
    tile = out.shape[2]
    top, full, rest = row * tile, w // tile, w % tile  # full tiles across, pixels of the partial last one
    rows = min(tile, h - top)
    for first, image in parts:
        src, c = image[top : top + rows], image.shape[2]
        dst = out[:, first : first + c, :rows]
        dst[:full] = src[:, : full * tile].reshape(rows, full, tile, c).transpose(1, 3, 0, 2)
        if rest:
            dst[full, :, :, :rest] = src[:, full * tile :].transpose(2, 0, 1)
    out[:, :, rows:] = 0  # below the frame's last pixel row
    if rest:
        out[full, :, :, rest:] = 0  # right of its last pixel column
    return out


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
        """The settings of a full config; ValueError naming the key for an unknown format or dtype, or, with
        ``format=array``, a folder that is a file or lies below one (:func:`mcd.core.paths.folder_to_be`). A
        config without ``data.train_store`` reads EXR (the behaviour before the key existed)."""
        ts = cfg.data.get("train_store") or {}
        fmt, dtype = str(ts.get("format", "exr")), str(ts.get("dtype", "float32"))
        if fmt not in FORMATS:
            raise ValueError(f"data.train_store.format={fmt!r}: give one of {list(FORMATS)} "
                             "(docs/training_store.md)")
        if dtype not in DTYPES:
            raise ValueError(f"data.train_store.dtype={dtype!r}: give one of {list(DTYPES)} "
                             "(docs/training_store.md)")
        folder = ts.get("dir")
        # ~ is the home folder, as in paths.data_dir (a literal "~" folder in the working directory before)
        root = (Path(str(folder)).expanduser() if folder
                else resolve_data_dir(cfg.paths.data_dir) / str(cfg.data.name) / f".train_{dtype}")
        if fmt == "array":
            folder_to_be("data.train_store.dir", root)
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
        self.tile, self.height, self.width = int(meta["tile"]), int(meta["height"]), int(meta["width"])
        # the channels a clip reads, as runs of consecutive stored channels: (first, end) in the store
        self._runs: list[tuple[int, int]] = []
        for b in self.buffers:
            c0, c1 = self.ranges[b]
            if self._runs and self._runs[-1][1] == c0:
                self._runs[-1] = (self._runs[-1][0], c1)
            else:
                self._runs.append((c0, c1))
        self._maps: dict[str, tuple[mmap.mmap, np.ndarray, int]] = {}
        #: ``store.json`` open with a shared ``flock`` while this store is read (:meth:`open`)
        self._reading: BinaryIO | None = None

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
        meta = read_meta(path, pack_command)
        check_meta(meta, settings, data_cfg, buffers, path)
        store = cls(settings.dir, meta, pack_command, buffers)
        store._reading = open(path, "rb")  # noqa: SIM115  # held, shared, while this store is read
        fcntl.flock(store._reading, fcntl.LOCK_SH)
        return store

    def scene_path(self, scene: str) -> Path:
        return self.root / f"{scene}.npy"

    def record_path(self, scene: str) -> Path:
        return self.root / f"{scene}.json"

    def record(self, scene: str) -> dict:
        """The scene's pack record (``{"frames": {...}}``; empty if nothing was packed); TrainStoreError
        naming the file and its fix when it is not a record (:func:`record_problem`)."""
        p = self.record_path(scene)
        if not p.is_file():
            return {"frames": {}}
        record, why = read_checked_json(p, record_problem)
        if why:
            raise TrainStoreError(f"{p} is corrupt ({why}); delete it and pack again, which packs the "
                                  f"scene's frames again: {self.pack_command}")
        return record

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
    def _map(self, scene: str) -> tuple[mmap.mmap, np.ndarray, int]:
        """``(map, array, offset)``: the scene's ``.npy`` mapped read-only on first use in this process, the
        array over it, and the byte offset of its data. :meth:`clip` asks the kernel for exactly the tile runs
        it reads (``MADV_WILLNEED``) before copying, so a cold read fetches those, all at once, and little
        else (``MADV_RANDOM`` on top read no less and cost warm reads their fault-around; the figures are in
        docs/training_store.md)."""
        if scene not in self._maps:
            if torch.utils.data.get_worker_info() is not None:
                keep_freed_memory()  # a loader worker: a clip reuses the last one's pages (core/allocator.py)
            with open(self.scene_path(scene), "rb") as f:
                read_header = _NPY_HEADERS.get(np.lib.format.read_magic(f))
                if read_header is None:
                    raise TrainStoreError(f"{self.scene_path(scene)}: not a .npy file of version 1 or 2; "
                                          f"delete it and pack again: {self.pack_command}")
                shape, fortran, dtype = read_header(f)
                offset = f.tell()
                mm = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
            if fortran or dtype != self.dtype:
                raise TrainStoreError(f"{self.scene_path(scene)}: not a {self.dtype} C-order array; delete "
                                      f"it and pack again: {self.pack_command}")
            self._maps[scene] = (mm, np.ndarray(shape, dtype, buffer=mm, offset=offset), offset)
        return self._maps[scene]

    def _will_need(self, scene: str, frames: list[int], tile_rows: range, tile_cols: range) -> None:
        """Ask the kernel for the byte runs of these tiles (one run per frame and tile row) before reading."""
        mm, arr, offset = self._map(scene)
        strides = arr.strides
        for f in frames:
            for ty in tile_rows:
                start = offset + f * strides[0] + ty * strides[1] + tile_cols.start * strides[2]
                end = start + len(tile_cols) * strides[2]
                first = start - start % mmap.PAGESIZE
                mm.madvise(mmap.MADV_WILLNEED, first, end - first)

    def clip(self, scene: str, frames: list[int], crop: tuple[int, int, int, int] | None) -> dict[str, Any]:
        """``{buffer: float32 tensor [T, C, h, w], "scene": scene, "frame": LongTensor[T]}`` for the crop
        ``(y, x, h, w)`` (None: the whole frame) of ``frames``: what the EXR path's clip gives (the
        datamodule's contract, docs/architecture.md "Batches"). Reads only the tiles the crop covers, and
        copies each tile's part once, straight into the clip."""
        mm, t_ = self._map(scene)[1], self.tile
        y, x, h, w = crop if crop is not None else (0, 0, self.height, self.width)
        if y < 0 or x < 0 or h < 1 or w < 1 or y + h > self.height or x + w > self.width:
            raise ValueError(f"crop {(y, x, h, w)} (y, x, h, w) lies outside the {self.width}x{self.height} "
                             f"frames of {self.scene_path(scene)}")
        n_read = sum(c1 - c0 for c0, c1 in self._runs)
        dst = np.empty((len(frames), n_read, h, w), dtype=self.dtype)  # float16: converted once, below
        spans_y, spans_x = _spans(y, h, t_), _spans(x, w, t_)
        self._will_need(scene, frames, range(spans_y[0][0], spans_y[-1][0] + 1),
                        range(spans_x[0][0], spans_x[-1][0] + 1))
        for t, f in enumerate(frames):
            for ty, y0, y1 in spans_y:
                tiles = mm[f, ty]  # one contiguous run of the tile row: (tiles_x, channels, tile, tile)
                for tx, x0, x1 in spans_x:
                    src = tiles[tx, :, y0 - ty * t_ : y1 - ty * t_, x0 - tx * t_ : x1 - tx * t_]
                    part = dst[t, :, y0 - y : y1 - y, x0 - x : x1 - x]
                    d = 0
                    for c0, c1 in self._runs:
                        part[d : d + c1 - c0] = src[c0:c1]
                        d += c1 - c0
        clip = torch.from_numpy(dst).float()  # float16 -> float32 in torch's vectorised conversion
        out: dict[str, Any] = {}
        d = 0
        for b in self.buffers:
            n = self.ranges[b][1] - self.ranges[b][0]
            out[b] = clip[:, d : d + n]
            d += n
        out["scene"] = scene
        out["frame"] = torch.tensor(frames, dtype=torch.long)
        return out

    def __getstate__(self) -> dict:
        """Pickled without its memory maps: a DataLoader worker opens its own on first read."""
        return {**self.__dict__, "_maps": {}, "_reading": None}


def readers_elsewhere(root: Path) -> bool:
    """Whether an open :class:`TrainStore` (:meth:`TrainStore.open`: a run training from the store at
    ``root``, in any process) holds its shared lock on ``store.json`` now; probed with an exclusive lock taken
    and dropped at once."""
    path = root / "store.json"
    if not path.is_file():
        return False
    with open(path, "rb") as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)  # dropped when f closes
        except BlockingIOError:
            return True
    return False


def _spans(start: int, size: int, tile: int) -> list[tuple[int, int, int]]:
    """``(tile index, first, end)`` in pixels of each tile that ``[start, start + size)`` covers, clipped."""
    return [(i, max(start, i * tile), min(start + size, (i + 1) * tile))
            for i in range(start // tile, -(-(start + size) // tile))]


#: The keys of ``store.json`` and the type of each value (``channels``: ``{buffer: [first, end]}``).
META_TYPES = {"version": int, "dtype": str, "tile": int, "width": int, "height": int, "profile": str,
              "channels": dict}


def meta_problem(meta: Any) -> str | None:
    """What is wrong with a parsed ``store.json`` (None: it has every key of :data:`META_TYPES` with its
    type, and channel ranges of two integers)."""
    if not isinstance(meta, dict):
        return f"a JSON {type(meta).__name__}, not an object"
    bad = [k for k, t in META_TYPES.items()
           if not isinstance(meta.get(k), t) or isinstance(meta.get(k), bool)]
    if bad:
        return f"missing or mistyped: {', '.join(bad)}"
    ranges = [b for b, r in meta["channels"].items()
              if not (isinstance(r, list) and len(r) == 2 and all(isinstance(c, int) for c in r))]
    if ranges:
        return f"channels of {', '.join(ranges)} are not [first, end]"
    unknown = [b for b in meta["channels"] if b not in CHANNELS]
    if unknown:
        return f"unknown buffer(s) {', '.join(unknown)}"
    # the layout the pack writes (buffers in table order, each its channels): an edited range read one
    # buffer's channels as another's (a run trained on swapped input and target, its frames' CRCs intact)
    layout = {b: list(r) for b, r in channel_ranges(meta["channels"]).items()}
    if layout != meta["channels"]:
        return f"channel ranges {meta['channels']} are not the pack's layout {layout}"
    return None


def read_checked_json(path: Path, problem: Callable[[Any], str | None]) -> tuple[Any, str | None]:
    """``(object, why)``: the JSON at ``path`` and what ``problem`` finds wrong with it (None: nothing), or
    ``(None, why)`` when the file is not readable JSON (the store's and the pack records' one reading)."""
    try:
        obj = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        return None, f"not readable JSON: {type(err).__name__}"
    return obj, problem(obj)


def read_meta(path: Path, pack_command: str) -> dict:
    """The ``store.json`` at ``path``; TrainStoreError naming the file and its fix when it is corrupt (not
    JSON, or :func:`meta_problem`)."""
    meta, why = read_checked_json(path, meta_problem)
    if why:
        raise TrainStoreError(f"{path} is corrupt ({why}); delete {path.parent} and pack it again: "
                              f"{pack_command}")
    return meta


def record_problem(record: Any) -> str | None:
    """What is wrong with a parsed ``<scene>.json`` pack record (None: ``{"frames": {frame: {"sources":
    str, ...}}}``)."""
    frames = record.get("frames") if isinstance(record, dict) else None
    if not isinstance(frames, dict):
        return "no object 'frames'"
    bad = [f for f, e in frames.items() if not (isinstance(e, dict) and isinstance(e.get("sources"), str))]
    return f"frame(s) {', '.join(bad[:3])} without their sources" if bad else None


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
    """The ``python -m mcd.pack`` command that packs ``buffers`` with a store's overrides."""
    listed = ",".join(b for b in BUFFERS if b in set(buffers))
    return shlex.join(["python", "-m", "mcd.pack", *overrides, f"render.buffers=[{listed}]"])

"""Float EXR files via the OpenEXR package (docs/benchmark.md, "Data protocol": everything HDR, linear,
float).

Writes are atomic (:func:`mcd.core.atomic_write.atomic_write`: a temporary file in the same folder, then
renamed), so an interrupted render never leaves a half-written file under a final name; the file gets the mode
the umask gives a new file. A file that OpenEXR cannot read, or whose size or checksum differs from the
manifest, raises :class:`CorruptEXRError`, whose message names the file and the command that
re-renders it. Every read checks the header first (:func:`read_header`, no pixels read): a data window above
:data:`MAX_PIXELS` is refused before anything is allocated (docs/reliability.md, "Denoising your frames").
A readable file in another channel layout (a layered frame of ``mcd.denoise``) raises
:class:`EXRLayoutError`, which says what was expected and what was found, and is never called corrupt.
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import OpenEXR

from mcd.core.atomic_write import atomic_write

CHANNEL_NAMES: dict[int, tuple[str, ...]] = {1: ("Y",), 2: ("U", "V"), 3: ("R", "G", "B")}
#: The largest data window read (width x height): 16384 x 8192, 512 MiB per float channel. A header that
#: declares more is refused before its pixels are allocated.
MAX_PIXELS = 16384 * 8192
_FIX = "the file is damaged: write, render or copy it again"


class CorruptEXRError(RuntimeError):
    """A stored EXR is truncated, unreadable or does not match its manifest entry."""

    def __init__(self, path: Path | str, reason: str, fix: str):
        self.path = Path(path)
        self.fix = fix
        super().__init__(f"{path}: truncated or corrupt EXR ({reason}). Fix: {fix}")


class EXRLayoutError(ValueError):
    """A readable EXR whose channels are not the layout the reader reads; the message names both."""


class EXRSizeError(ValueError):
    """An EXR header declaring an empty data window or one above :data:`MAX_PIXELS`."""


def read_header(path: Path | str, fix: str | None = None) -> tuple[int, int, list[str]]:
    """``(width, height, channel names)`` of an EXR's (first part's) header, without reading its pixels.

    CorruptEXRError (naming ``fix``) if OpenEXR cannot read the header; EXRSizeError if its data window is
    empty or above :data:`MAX_PIXELS`.
    """
    try:
        with OpenEXR.File(str(path), header_only=True) as f:  # closing it empties the header dict
            header = f.header()
            (x0, y0), (x1, y1) = (tuple(int(v) for v in corner) for corner in header["dataWindow"])
            names = [str(c.name) for c in header["channels"]]
    except Exception as exc:  # OpenEXR raises RuntimeError / ValueError / KeyError on damaged files
        raise CorruptEXRError(path, f"unreadable header: {exc}", fix or _FIX) from exc
    width, height = x1 - x0 + 1, y1 - y0 + 1
    if width <= 0 or height <= 0 or width * height > MAX_PIXELS:
        raise EXRSizeError(f"{path}: the header declares a {width}x{height} image (data window {x0},{y0} to "
                           f"{x1},{y1}); refused before reading: frames are read up to {MAX_PIXELS} pixels "
                           "(mcd.data.exr.MAX_PIXELS). Check how the file was written")
    return width, height, names


def write_exr(path: Path, image: np.ndarray, compress: bool = True) -> None:
    """Write an ``(H, W)`` or ``(H, W, C)`` array (C in 1..3) as a float32 EXR, atomically.

    ``compress`` picks ZIP compression: worth it for smooth images (G-buffers, motion: 2-5x smaller), not for
    noisy renders, which it shrinks by about 1% at 7x the write time (measured on 960x540 float images).
    """
    img = np.asarray(image, dtype=np.float32)
    if img.ndim == 2:
        img = img[..., None]
    if img.ndim != 3 or img.shape[2] not in CHANNEL_NAMES:
        raise ValueError(f"{path}: cannot store an array of shape {img.shape} (need H x W x C, C in 1..3)")
    names = CHANNEL_NAMES[img.shape[2]]
    channels = {n: np.ascontiguousarray(img[..., i]) for i, n in enumerate(names)}
    compression = OpenEXR.ZIP_COMPRESSION if compress else OpenEXR.NO_COMPRESSION
    header = {"compression": compression, "type": OpenEXR.scanlineimage}
    atomic_write(path, lambda tmp: OpenEXR.File(header, channels).write(str(tmp)))


def read_exr(path: Path, fix: str | None = None) -> np.ndarray:
    """Read an EXR of :func:`write_exr` as float32 ``(H, W, C)``.

    The header is checked first (:func:`read_header`). CorruptEXRError (its message ends with ``fix``, by
    default: write or copy the file again) if unreadable; EXRLayoutError if the channels are not exactly one
    of :data:`CHANNEL_NAMES`' sets.
    """
    if not Path(path).is_file():
        raise FileNotFoundError(f"{path}: missing EXR. Fix: {fix or _FIX}")
    _, _, found = read_header(path, fix)
    if not any(set(found) == set(names) for names in CHANNEL_NAMES.values()):
        layered = "R" in found and any("." in n for n in found)
        raise EXRLayoutError(
            f"{path}: channels {sorted(found)}; mcd.data.exr.read_exr reads a file of write_exr, with "
            "exactly the channels Y, or U and V, or R, G and B. "
            + ("This is a layered frame (colour plus albedo/normal/depth layers, as "
               "mcd.denoise.render_frames writes): read it with mcd.denoise.frames.read_frame. The file "
               "itself is fine"
               if layered else "The file is readable; read it with OpenEXR.File for this layout")
            + (f". For a store file: {fix}" if fix else ""))
    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            chans = f.channels()
            names = next(n for n in CHANNEL_NAMES.values() if set(chans) == set(n))
            return np.stack([np.asarray(chans[n].pixels, dtype=np.float32) for n in names], axis=-1)
    except Exception as exc:  # OpenEXR raises RuntimeError or ValueError on damaged files
        raise CorruptEXRError(path, str(exc), fix or _FIX) from exc


def sha256(path: Path) -> str:
    """Hex SHA-256 of a file (the manifest's per-file checksum)."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def count_bad(image: np.ndarray, allow_negative: bool) -> dict[str, int]:
    """Counts of NaN, +-Inf and (unless allowed) negative values: recorded per file in the manifest."""
    img = np.asarray(image)
    finite = np.isfinite(img)
    return {
        "nan": int(np.isnan(img).sum()),
        "inf": int(np.isinf(img).sum()),
        "negative": 0 if allow_negative else int((finite & (img < 0)).sum()),
    }


def sanitise(image: np.ndarray, allow_negative: bool) -> tuple[np.ndarray, int]:
    """Replace NaN/Inf (and negatives unless allowed) by 0; return the image and the count replaced."""
    bad = ~np.isfinite(image)
    if not allow_negative:
        bad |= image < 0
    n = int(bad.sum())
    if n:
        image = np.where(bad, np.float32(0), image).astype(np.float32)
    return image, n

"""A sequence of EXR frames from disk as a network's input buffers (docs/denoise.md, "Frames from disk").

Naming (one frame = one colour file, in name order):

- colour: the channels ``R``, ``G``, ``B`` of ``<stem>.exr`` (linear HDR radiance, any sample count);
- G-buffers, either as layers of the same file or as sibling files ``<stem>.<layer>.exr``:
  ``albedo`` (channels ``albedo.R/G/B``; a sibling's ``R/G/B``), ``normal`` (``normal.X/Y/Z`` or
  ``normal.R/G/B``; world or camera space, in [-1, 1]) and ``depth`` (one channel: ``depth.Z``, ``depth.Y``,
  ``depth.R`` or ``Z``; a sibling's single channel): first-hit albedo, shading normal and distance, as
  Mitsuba's ``aov`` integrator writes them (docs/architecture.md, "The store"); layer names ``alb``, ``N``,
  ``nn``, ``dd`` are accepted too.

An input is a folder (every ``*.exr`` in it that is not a sibling layer file), one or more files, or a glob
pattern. Every frame and layer must have one size. Colour and G-buffers go through
:mod:`mcd.data.exposure` exactly as the training data: colour scaled so that frame 0's mean is the
checkpoint's ``data.exposure_target`` (the same scale for the whole sequence, undone on output), depth divided
by frame 0's median, NaN/Inf/negative values replaced by 0 and counted.
"""

from __future__ import annotations

import glob
import logging
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import OpenEXR

from mcd.data.exposure import auto_exposure, depth_scale, normalise

log = logging.getLogger(__name__)

LAYERS = ("albedo", "normal", "depth")
#: Channel suffixes of each layer, in the order they are tried (the first complete set wins).
LAYER_CHANNELS: dict[str, tuple[tuple[str, ...], ...]] = {
    "albedo": (("R", "G", "B"),),
    "normal": (("X", "Y", "Z"), ("R", "G", "B")),
    "depth": (("Z",), ("Y",), ("R",), ("V",)),
}
#: Layer names accepted inside a frame's file (Mitsuba's ``aov`` examples name them ``alb``, ``nn``, ``dd``).
ALIASES = {"albedo": ("albedo", "alb"), "normal": ("normal", "N", "nn"), "depth": ("depth", "dd")}


def _candidates(layer: str, in_file: bool) -> list[tuple[str, ...]]:
    """Channel-name sets that hold ``layer`` in a frame's own file (``in_file``) or in its sibling file."""
    prefixes = [f"{a}." for a in ALIASES[layer]] + ([] if in_file else [""])
    found = [tuple(p + c for c in names) for p in prefixes for names in LAYER_CHANNELS[layer]]
    return found + ([("Z",)] if in_file and layer == "depth" else [])


class FrameError(ValueError):
    """A frame file cannot be used as it is: the message names the file and what to do."""


def read_channels(path: Path) -> dict[str, np.ndarray]:
    """Every channel of an EXR file as float32 ``(H, W)`` arrays; FrameError naming the file if unreadable."""
    try:
        with OpenEXR.File(str(path), separate_channels=True) as f:
            return {name: np.asarray(ch.pixels, dtype=np.float32) for name, ch in f.channels().items()}
    except Exception as exc:  # OpenEXR raises RuntimeError / ValueError on damaged or foreign files
        raise FrameError(f"{path}: not a readable EXR file ({exc}); give linear HDR EXR frames") from exc


def write_layers(path: Path, colour: np.ndarray, layers: dict[str, np.ndarray] | None = None) -> None:
    """Write a frame in this module's naming: ``R,G,B``, ``albedo.R/G/B``, ``normal.X/Y/Z``, ``depth.Z``."""
    chans = {c: np.ascontiguousarray(colour[..., i], dtype=np.float32) for i, c in enumerate("RGB")}
    for name, img in (layers or {}).items():
        suffixes = LAYER_CHANNELS[name][0]
        for i, s in enumerate(suffixes):
            chans[f"{name}.{s}"] = np.ascontiguousarray(img[..., i], dtype=np.float32)
    path.parent.mkdir(parents=True, exist_ok=True)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    OpenEXR.File(header, chans).write(str(path))


def _pick(chans: dict[str, np.ndarray], candidates: list[tuple[str, ...]]) -> np.ndarray | None:
    for keys in candidates:
        if all(k in chans for k in keys):
            return np.stack([chans[k] for k in keys], axis=-1)
    return None


def is_sibling(path: Path) -> bool:
    """Whether ``path`` is a sibling layer file ``<stem>.<layer>.exr`` (not a colour frame)."""
    return Path(path.stem).suffix.lstrip(".") in LAYERS


def find_frames(inputs: list[str]) -> list[Path]:
    """The colour frames named by ``inputs`` (folders, files, glob patterns), in order; FrameError if none."""
    frames: list[Path] = []
    for item in inputs:
        p = Path(item).expanduser()
        if p.is_dir():
            frames += sorted(f for f in p.glob("*.exr") if not is_sibling(f))
        elif p.is_file():
            frames.append(p)
        else:
            hits = sorted(Path(h) for h in glob.glob(str(p)) if not is_sibling(Path(h)))
            if not hits:
                raise FrameError(f"{item}: no such file or folder, and no EXR file matches it as a pattern")
            frames += hits
    if not frames:
        raise FrameError(f"{' '.join(inputs)}: no EXR colour frames found (a folder's *.exr, sibling layer "
                         "files <stem>.albedo.exr / .normal.exr / .depth.exr excluded)")
    return frames


def read_frame(path: Path, want: set[str]) -> dict[str, np.ndarray]:
    """Raw ``colour`` and the layers of ``want`` (subset of :data:`LAYERS`) of one frame, ``(H, W, C)``."""
    chans = read_channels(path)
    colour = _pick(chans, [tuple(p + c for c in "RGB") for p in ("", "colour.", "color.", "rgb.")])
    if colour is None:
        raise FrameError(f"{path}: no colour channels R, G, B (found {sorted(chans)[:8]}); write the noisy "
                         "render's colour as channels R, G, B")
    out = {"colour": colour}
    for layer in sorted(want):
        img = _pick(chans, _candidates(layer, in_file=True))
        sibling = path.with_name(f"{path.stem}.{layer}.exr")
        if img is None and sibling.is_file():
            sib = read_channels(sibling)
            img = _pick(sib, _candidates(layer, in_file=False))
            if img is None and layer == "depth" and len(sib) == 1:
                img = next(iter(sib.values()))[..., None]
            if img is None:
                raise FrameError(f"{sibling}: channels {sorted(sib)} are not a {layer} layer; write "
                                 f"{'/'.join(LAYER_CHANNELS[layer][0])}")
        if img is None:
            names = "/".join(f"{layer}.{c}" for c in LAYER_CHANNELS[layer][0])
            raise FrameError(f"{path}: missing layer {layer!r} (no channels {names} in the file, no sibling "
                             f"file {sibling.name}); the checkpoint reads {', '.join(sorted(want))}: add the "
                             "layer to every frame (docs/denoise.md, 'Frames from disk')")
        if img.shape[:2] != colour.shape[:2]:
            raise FrameError(f"{path}: layer {layer!r} is {img.shape[1]}x{img.shape[0]} but the colour is "
                             f"{colour.shape[1]}x{colour.shape[0]}; render every layer at the frame's size")
        out[layer] = img
    return out


@dataclass
class FrameSequence:
    """Frames of one sequence, loaded on demand and normalised like training data (module docstring).

    ``colour_key`` is the buffer the network reads the colour as (``c{budget}`` for uniform methods).
    """

    paths: list[Path]
    want: set[str]
    colour_key: str
    exposure_target: float
    exposure: float = 1.0
    depth_scale: float = 1.0
    size: tuple[int, int] = (0, 0)
    bad: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        first = read_frame(self.paths[0], self.want)
        self.size = first["colour"].shape[:2]
        exposure = auto_exposure(first["colour"], self.exposure_target)
        if exposure is None:
            log.warning("%s: frame 0 is black; exposure left at 1", self.paths[0])
        self.exposure = exposure or 1.0
        if "depth" in first:
            self.depth_scale = depth_scale(first["depth"])

    def __len__(self) -> int:
        return len(self.paths)

    def load(self, i: int) -> dict[str, np.ndarray]:
        """Frame ``i``'s buffers, normalised (``colour_key`` and the wanted layers), ``(H, W, C)`` float32."""
        path = self.paths[i]
        raw = read_frame(path, self.want)
        if raw["colour"].shape[:2] != self.size:
            h, w = raw["colour"].shape[:2]
            raise FrameError(f"{path}: frame {i} is {w}x{h} but frame 0 ({self.paths[0].name}) is "
                             f"{self.size[1]}x{self.size[0]}; a sequence keeps one size (denoise it apart)")
        out = {}
        for name, img in raw.items():
            key = self.colour_key if name == "colour" else name
            out[key], n_bad = normalise(img, name, self.exposure, self.depth_scale, colour=name == "colour")
            if n_bad:
                self.bad[f"{path.name}:{name}"] = n_bad
                log.warning("%s: %d NaN/Inf/negative values in %s replaced by 0", path, n_bad, name)
        return out

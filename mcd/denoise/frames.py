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
:mod:`mcd.data.exposure` as the training data: colour scaled so that frame 0's mean (a robust one, fireflies
clamped: :func:`mcd.data.exposure.input_exposure`; the first frame that is not black where frame 0 is) is the
checkpoint's ``data.exposure_target`` (the same scale for the whole sequence, undone on output), depth
divided by the median of the first frame with a hit, NaN/Inf/negative values replaced by 0 and counted.
"""

from __future__ import annotations

import glob
import logging
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import OpenEXR

from mcd.data import exr
from mcd.data.exposure import EXPOSURE_CLAMP, FrameExposure, depth_scale, measure_exposure, normalise

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


def read_header(path: Path) -> tuple[tuple[int, int], list[str]]:
    """``((height, width), channel names)`` of an EXR's header, no pixels read; FrameError naming the file if
    it is unreadable or declares an image above :data:`mcd.data.exr.MAX_PIXELS` (a memory bomb)."""
    try:
        width, height, names = exr.read_header(path)
    except (exr.CorruptEXRError, exr.EXRSizeError) as exc:
        raise FrameError(f"{path}: not a readable EXR frame ({exc}); give linear HDR EXR frames") from exc
    return (height, width), names


def read_channels(path: Path, size: tuple[int, int] | None = None) -> dict[str, np.ndarray]:
    """Every channel of an EXR file as float32 ``(H, W)`` arrays; FrameError naming the file if unreadable,
    or if its header declares another ``size`` ``(H, W)`` than expected (checked before reading pixels)."""
    got, _ = read_header(path)
    if size is not None and got != size:
        raise FrameError(f"{path}: {got[1]}x{got[0]}, expected {size[1]}x{size[0]}")
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


def _pick(names: Iterable[str], candidates: list[tuple[str, ...]]) -> tuple[str, ...] | None:
    """The first channel-name set of ``candidates`` that ``names`` holds completely."""
    have = set(names)
    return next((keys for keys in candidates if all(k in have for k in keys)), None)


def is_sibling(path: Path) -> bool:
    """Whether ``path`` is a sibling layer file ``<stem>.<layer>.exr`` (not a colour frame)."""
    return Path(path.stem).suffix.lstrip(".") in LAYERS


def siblings(path: Path) -> list[Path]:
    """The sibling layer files of the frame ``path`` that exist."""
    return [s for s in (path.with_name(f"{path.stem}.{layer}.exr") for layer in LAYERS) if s.is_file()]


def _is_frame(path: Path) -> bool:
    """A folder's ``*.exr`` that is a colour frame: not a sibling layer file, not hidden (``._x.exr`` of
    macOS, the ``.tmp.exr`` temporaries of an atomic write)."""
    return not path.name.startswith(".") and not is_sibling(path)


def _frames_among(paths: Iterable[Path]) -> list[Path]:
    """The colour frames among ``paths`` (:func:`_is_frame`), sorted. A sibling layer file whose frame is not
    there (``x.albedo.exr`` without ``x.exr``) is left out with a warning naming it, never silently."""
    paths = sorted(paths)
    for p in paths:
        frame = p.with_name(f"{Path(p.stem).stem}.exr")
        if not p.name.startswith(".") and is_sibling(p) and not frame.exists():
            log.warning("%s: named as a sibling layer file (<stem>.%s.exr) of %s, which is not there: not "
                        "denoised; rename it (no layer name before .exr) to denoise it as a frame", p,
                        Path(p.stem).suffix.lstrip("."), frame.name)
    return [p for p in paths if _is_frame(p)]


def find_frames(inputs: list[str]) -> list[Path]:
    """The colour frames named by ``inputs`` (folders, files, glob patterns), in order.

    A folder gives its ``*.exr`` that are frames (:func:`_frames_among`: a sibling layer file without its
    frame is named in a warning). FrameError if none, if one is not a regular file (a FIFO, on which reading
    waits for ever), or if two frames share a name (their outputs would overwrite each other in ``-o``),
    naming both.
    """
    frames: list[Path] = []
    for item in inputs:
        p = Path(item).expanduser()
        if p.is_dir():
            frames += _frames_among(p.glob("*.exr"))
            other_case = sorted(q.name for q in p.iterdir() if q.suffix.lower() == ".exr" != q.suffix)
            if other_case:  # f0003.EXR was left out of the sequence without a word
                log.warning("%s: %s: not '.exr' in lower case, so not frames of the sequence; rename them to "
                            "denoise them", p, ", ".join(other_case))
        elif p.is_file():
            frames.append(p)
        else:
            hits = _frames_among(Path(h) for h in glob.glob(str(p)))
            if not hits:
                raise FrameError(f"{item}: no such file or folder, and no EXR file matches it as a pattern")
            frames += hits
    if not frames:
        raise FrameError(f"{' '.join(inputs)}: no EXR colour frames found (a folder's *.exr, sibling layer "
                         "files <stem>.albedo.exr / .normal.exr / .depth.exr and hidden files excluded)")
    seen: dict[str, Path] = {}
    for f in frames:
        if not f.is_file():  # a FIFO was waited on for ever; a device or a folder is no frame either
            raise FrameError(f"{f}: not a regular file (a FIFO, a device or a folder named like a frame); "
                             "give EXR files, or move it out of the folder")
        if f.stem in seen:
            same = seen[f.stem].resolve() == f.resolve()
            raise FrameError(
                f"{f}: {'given twice' if same else f'has the name of {seen[f.stem]}'}; the outputs are named "
                f"after the frame ({f.stem}.exr) and would overwrite each other. "
                + ("Give each frame once" if same else "Denoise the folders apart, each into its own -o"))
        seen[f.stem] = f
    return frames


def _layout(path: Path, want: set[str],
            size: tuple[int, int] | None) -> dict[str, tuple[Path, tuple[str, ...]]]:
    """Where each buffer of the frame ``path`` is: ``{buffer: (file, channel names)}`` for ``colour`` and the
    layers of ``want``, from the headers only; FrameError naming the file for a missing layer or a size that
    differs from the frame's (or from ``size``)."""
    shape, names = read_header(path)
    if size is not None and shape != size:
        raise FrameError(f"{path}: this frame is {shape[1]}x{shape[0]} but the first frame is {size[1]}x"
                         f"{size[0]}; a sequence keeps one size (denoise it apart)")
    colour = _pick(names, [tuple(p + c for c in "RGB") for p in ("", "colour.", "color.", "rgb.")])
    if colour is None:
        raise FrameError(f"{path}: no colour channels R, G, B (found {sorted(names)[:8]}); write the noisy "
                         "render's colour as channels R, G, B")
    out = {"colour": (path, colour)}
    for layer in sorted(want):
        keys = _pick(names, _candidates(layer, in_file=True))
        sibling = path.with_name(f"{path.stem}.{layer}.exr")
        if keys is not None:
            out[layer] = (path, keys)
            continue
        if not sibling.is_file():
            chans = "/".join(f"{layer}.{c}" for c in LAYER_CHANNELS[layer][0])
            raise FrameError(f"{path}: missing layer {layer!r} (no channels {chans} in the file, no sibling "
                             f"file {sibling.name}); the checkpoint reads {', '.join(sorted(want))}: add the "
                             "layer to every frame (docs/denoise.md, 'Frames from disk')")
        sib_shape, sib_names = read_header(sibling)
        keys = _pick(sib_names, _candidates(layer, in_file=False))
        if keys is None and layer == "depth" and len(sib_names) == 1:
            keys = (sib_names[0],)
        if keys is None:
            raise FrameError(f"{sibling}: channels {sorted(sib_names)} are not a {layer} layer; write "
                             f"{'/'.join(LAYER_CHANNELS[layer][0])}")
        if sib_shape != shape:
            raise FrameError(f"{sibling}: the {layer} layer is {sib_shape[1]}x{sib_shape[0]} but its frame "
                             f"{path.name} is {shape[1]}x{shape[0]}; render every layer at the frame's size")
        out[layer] = (sibling, keys)
    return out


def read_frame(path: Path, want: set[str], size: tuple[int, int] | None = None) -> dict[str, np.ndarray]:
    """Raw ``colour`` and the layers of ``want`` (subset of :data:`LAYERS`) of one frame, ``(H, W, C)``;
    ``size``: the ``(H, W)`` every file must have (checked on the headers before any pixel is read)."""
    layout = _layout(path, want, size)   # every file's size checked against the frame's (and ``size``)
    files: dict[Path, dict[str, np.ndarray]] = {}
    out = {}
    for name, (file, keys) in layout.items():
        if file not in files:
            files[file] = read_channels(file)
        out[name] = np.stack([files[file][k] for k in keys], axis=-1)
    return out


@dataclass
class FrameScan:
    """What :func:`check_frames` found in its one read of every frame: the sequence's ``(H, W)``, each
    frame's colour measured for the exposure (:func:`mcd.data.exposure.measure_exposure`; None: black), and
    the depth scale of the first frame whose depth layer holds a hit (``depth_from``; None: no frame does, or
    no depth layer is read)."""

    size: tuple[int, int]
    exposures: list[FrameExposure | None]
    depth_scale: float = 1.0
    depth_from: int | None = None


def check_frames(paths: list[Path], want: set[str], exposure_target: float) -> FrameScan:
    """Check every frame before the first is denoised: its header and its sibling layers' (readable, the
    layers of ``want`` present, one size across frames and layers), then its pixels (they decode: a truncated
    file is named here). FrameError naming the first bad file. The one read of the pixels also measures what
    :class:`FrameSequence` sets the sequence's exposure (towards ``exposure_target``) and depth scale from,
    so that no frame is read again before the work."""
    size = read_header(paths[0])[0]
    for i, p in enumerate(paths):
        (h, w), _ = read_header(p)
        if (h, w) != size:
            raise FrameError(f"{p}: frame {i} is {w}x{h} but frame 0 ({paths[0].name}) is "
                             f"{size[1]}x{size[0]}; a sequence keeps one size (denoise it apart)")
        _layout(p, want, size)
    scan = FrameScan(size, [])
    for i, p in enumerate(paths):
        frame = read_frame(p, want, size)
        scan.exposures.append(measure_exposure(frame["colour"], exposure_target))
        depth = frame.get("depth")
        if scan.depth_from is None and depth is not None and np.any(np.isfinite(depth) & (depth > 0)):
            scan.depth_scale, scan.depth_from = depth_scale(depth), i
    alpha = [p for p in paths if any(n == "A" or n.endswith(".A") for n in read_header(p)[1])]
    if alpha:  # the outputs are RGB: a user compositing with the input's alpha must know it is not carried
        log.warning("%s%s: an alpha channel (A), which is not denoised and not written to the outputs (they "
                    "hold R, G, B); copy it over from the input where you composite", alpha[0],
                    f" and {len(alpha) - 1} more frame(s)" if len(alpha) > 1 else "")
    return scan


#: How far (a factor) frame 0's exposure may lie from the median of the sequence's frames before the frame
#: nearest the median gives the sequence's exposure instead (:meth:`FrameSequence._first_exposure`).
EXPOSURE_SPREAD = 8.0


def refuse_clamping_exposure(given: float, measured: list[FrameExposure | None], where: Path,
                             target: float) -> None:
    """FrameError where ``--exposure`` brings the median lit frame's mean to :data:`EXPOSURE_CLAMP` or beyond
    (``measured``: each frame's, from :func:`check_frames`; ``where``: the frames' folder, named; ``target``:
    the mean the frames' own exposure brings them to): :meth:`FrameSequence.load` would then clamp most colour
    values to it, and every output would come out one constant (``--exposure 1e12`` on frames of mean about
    1). Named before any output is written, with the largest exposure that keeps the mean under the clamp."""
    means = [m.mean for m in measured if m is not None and m.mean > 0]
    if not means:
        return
    typical = float(np.median(means))
    if given * typical >= EXPOSURE_CLAMP:
        raise FrameError(
            f"{where}: --exposure {given:g} brings the frames' mean ({typical:.4g}, the median of the lit "
            f"frames') to {given * typical:.4g}, at or above the clamp {EXPOSURE_CLAMP:g} that every colour "
            f"value is held to, so most of each frame would be clamped and the outputs one constant; give "
            f"an exposure below {EXPOSURE_CLAMP / typical:.4g}, or none (the frames' own, "
            f"x{target / typical:.4g})")


@dataclass
class FrameSequence:
    """Frames of one sequence, loaded on demand and normalised like training data (module docstring).

    ``colour_key`` is the buffer the network reads the colour as (``c{budget}`` for uniform methods).
    """

    paths: list[Path]
    want: set[str]
    colour_key: str
    exposure_target: float
    #: ``--exposure``: the sequence's exposure as given (None: from frame 0, :func:`input_exposure`)
    given_exposure: float | None = None
    #: what :func:`check_frames` measured of these frames (None: read them here)
    scan: FrameScan | None = None
    exposure: float = 1.0
    depth_scale: float = 1.0
    size: tuple[int, int] = (0, 0)
    bad: dict[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        scan = self.scan or check_frames(self.paths, self.want, self.exposure_target)
        self.size = scan.size
        if self.given_exposure is not None:
            exposure = self.given_exposure
            log.info("exposure x%.4g for every frame and score (--exposure)", exposure)
            refuse_clamping_exposure(exposure, scan.exposures, self.paths[0].parent, self.exposure_target)
            self._warn_far(exposure, scan.exposures)
        else:
            exposure = self._first_exposure(scan.exposures)
        self.exposure = exposure or 1.0
        if "depth" in self.want:
            self.depth_scale = self._depth_scale(scan)

    def _warn_far(self, given: float, measured: list[FrameExposure | None]) -> None:
        """A warning where ``--exposure`` lies more than :data:`EXPOSURE_SPREAD` times off the median of the
        lit frames' own exposures: the network then reads its input far from the mean it was trained at
        (``data.exposure_target``), and its outputs are not what it was trained for (``--exposure 1e-45``
        made every input black to it, and the outputs came out 20 times too bright, without a word)."""
        lit = [m.exposure for m in measured if m is not None]
        typical = float(np.median(lit)) if lit else None
        if typical and not EXPOSURE_SPREAD ** -1 <= given / typical <= EXPOSURE_SPREAD:
            log.warning("--exposure x%.4g is %.3g times the exposure the frames' own means give (x%.4g, the "
                        "median of the lit frames'): the network reads its input far from the mean it was "
                        "trained at, and its outputs are not what it was trained for; give an exposure "
                        "nearer x%.4g, or none", given, given / typical, typical, typical)

    def _depth_scale(self, scan: FrameScan) -> float:
        """The depth scale (:func:`depth_scale`) of the first frame whose depth layer holds a hit (a positive
        finite distance), logged where that is not frame 0: a frame 0 that hits nothing (the sky) gave 1, and
        a sequence in centimetres then reached the network hundreds of times too far."""
        if scan.depth_from:
            log.info("%s: frames 0-%d hit nothing (depth 0); depth scale %.4g from frame %d", self.paths[0],
                     scan.depth_from - 1, scan.depth_scale, scan.depth_from)
        return scan.depth_scale if scan.depth_from is not None else 1.0

    def _first_exposure(self, measured: list[FrameExposure | None]) -> float | None:
        """The exposure of the first frame that is not black (``measured``: each frame's, from
        :func:`check_frames`), logged where that is not frame 0; None (a warning) when every frame is. A
        sequence that fades in from black must not take 1 from its black frame 0: its HDR frames would reach
        the network at their own scale. Nor may it take the exposure of a frame far darker or brighter than
        the rest (a fade from near black: frame 0 at a thousandth of the others made them come out 2.7 times
        too bright): where that frame's exposure is more than :data:`EXPOSURE_SPREAD` times off the median of
        every lit frame's, the frame nearest the median gives it, with a warning naming both (``--exposure``
        chooses another). The outlier warning of :func:`mcd.data.exposure.input_exposure` (fireflies clamped)
        is given for the frame whose exposure is taken, whichever it is."""
        lit = [(i, m) for i, m in enumerate(measured) if m is not None]
        if not lit:
            log.warning("%s: every frame is black; exposure left at 1", self.paths[0])
            return None
        first, exposure = lit[0][0], lit[0][1].exposure
        if first:
            log.info("%s: frames 0-%d are black; exposure x%.4g from frame %d", self.paths[0], first - 1,
                     exposure, first)
        typical = float(np.median([m.exposure for _, m in lit]))
        if EXPOSURE_SPREAD ** -1 <= exposure / typical <= EXPOSURE_SPREAD:
            lit[0][1].warn_outliers(str(self.paths[first]))
            return exposure
        near, chosen = min(lit, key=lambda item: abs(np.log(item[1].exposure / typical)))
        log.warning("%s: its exposure x%.4g is %.3g times the median of the sequence's frames; one exposure "
                    "holds for every frame, so it is x%.4g, from frame %d (%s), nearest the median (give "
                    "--exposure to choose another, or denoise the frames apart)", self.paths[first], exposure,
                    exposure / typical, chosen.exposure, near, self.paths[near].name)
        chosen.warn_outliers(str(self.paths[near]))
        return chosen.exposure

    def __len__(self) -> int:
        return len(self.paths)

    def load(self, i: int) -> dict[str, np.ndarray]:
        """Frame ``i``'s buffers, normalised (``colour_key`` and the wanted layers), ``(H, W, C)`` float32."""
        path = self.paths[i]
        raw = read_frame(path, self.want, self.size)
        out = {}
        for name, img in raw.items():
            key = self.colour_key if name == "colour" else name
            out[key], n_bad = normalise(img, name, self.exposure, self.depth_scale, colour=name == "colour")
            if n_bad:
                self.bad[f"{path.name}:{name}"] = n_bad
                log.warning("%s: %d NaN/Inf/negative values in %s replaced by 0", path, n_bad, name)
            over = out[key] > EXPOSURE_CLAMP if name == "colour" else None
            if over is not None and over.any():  # one pixel of 3e38 moved the network's whole output
                out[key][over] = EXPOSURE_CLAMP
                how = ("--exposure" if self.given_exposure is not None
                       else f"the frames' own, which brings a frame's mean to {self.exposure_target:g}")
                log.warning("%s: %d colour values above %g after the exposure x%.4g (%s) clamped to it: a "
                            "broken render? check the file", path, int(over.sum()), EXPOSURE_CLAMP,
                            self.exposure, how)
        return out

"""Input (a) of ``mcd.denoise``: a sequence of EXR frames on disk (docs/denoise.md, "Frames from disk").

For the methods that read a uniform render (U-Net = row A, other rows without AS, RAE, FastDVDnet, OIDN,
``noisy``): each frame's colour is fed as the uniform render ``c_s`` the method was trained on, with the
G-buffers it reads, in sequence order; the model is reset once at the start, so temporal methods carry their
state across the sequence, and a model with a frame window (FastDVDnet: 2 before, 2 after) gets its
neighbours, edge frames repeated (as the test datamodule does, docs/architecture.md "Batches").

With a :class:`mcd.denoise.resume.Record`, frames a previous run finished with the same settings are not
written again (a method without temporal state does not even run them), and every finished frame is
recorded as it is written.
"""

from __future__ import annotations

import logging
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from mcd.data.exposure import scale
from mcd.data.exr import read_exr
from mcd.denoise.frame_scores import Scorer
from mcd.denoise.frames import LAYERS, FrameError, FrameScan, FrameSequence
from mcd.denoise.output import hwc, write_frame
from mcd.denoise.precision import layout, prepare, running
from mcd.denoise.resume import Record
from mcd.denoise.tiles import PROBE, TiledModel, bytes_per_pixel, tile_size
from mcd.denoise.weights import Loaded

log = logging.getLogger(__name__)


def colour_key(loaded: Loaded) -> str:
    """The buffer a uniform method reads its colour from (``c{budget}``); FrameError for adaptive methods."""
    reads = set(loaded.model.required_buffers())
    colour = sorted(reads - set(LAYERS))
    if loaded.adaptive or len(colour) != 1:
        raise FrameError(
            f"{loaded.source}: experiment {loaded.experiment} samples adaptively (it reads {sorted(reads)}): "
            "it needs a renderer, not finished frames; give a Mitsuba scene with --scene path/to/scene.xml, "
            "or a checkpoint of a uniform method (e.g. --checkpoint unet-cpu-small)")
    return colour[0]


def wanted_layers(loaded: Loaded) -> set[str]:
    """The G-buffer layers (of :data:`mcd.denoise.frames.LAYERS`) the model reads from each frame."""
    return set(loaded.model.required_buffers()) & set(LAYERS)


def exposure_target(loaded: Loaded) -> float:
    """The mean the checkpoint's inputs were brought to in training (``data.exposure_target``)."""
    return float(loaded.cfg.data.get("exposure_target", 0.5))


def to_tensor(img: np.ndarray, device: torch.device) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(img.transpose(2, 0, 1)))[None].to(device)


def denoise_frames(loaded: Loaded, paths: list[Path], out_dir: Path, device: torch.device,
                   max_memory_mb: float, overlap: int, progress: bool = True,
                   dtype: torch.dtype | None = None, record: Record | None = None,
                   meta: dict[str, Any] | None = None,
                   references: list[Path] | None = None, exposure: float | None = None,
                   scan: FrameScan | None = None) -> dict[str, Any]:
    """Denoise ``paths`` (one sequence, checked by :func:`mcd.denoise.frames.check_frames`) into ``out_dir``
    with autocast to ``dtype`` (None: fp32; mcd/denoise/precision.py); returns a summary (frames, tiles,
    sanitised, s, resumed). ``record``: resume and record finished frames (module docstring), its JSON
    carrying ``meta`` and the summary so far. ``references``: one per frame, scored
    (:mod:`mcd.denoise.frame_scores`; a frame finished before is scored from its written EXR).
    ``exposure``: ``--exposure``, the one exposure of the network's input and the scores (None: frame 0's).
    ``scan``: what :func:`mcd.denoise.frames.check_frames` measured of ``paths`` (None: read them again)."""
    model = prepare(loaded.model.to(device), dtype)
    key = colour_key(loaded)
    want = wanted_layers(loaded)
    seq = FrameSequence(paths, want, key, exposure_target(loaded), exposure, scan)
    past, future = (int(v) for v in model.window)
    cache: dict[int, dict[str, torch.Tensor]] = {}

    def frame(i: int) -> dict[str, torch.Tensor]:
        i = min(max(i, 0), len(seq) - 1)
        if i not in cache:
            cache[i] = {k: layout(to_tensor(v, device), dtype) for k, v in seq.load(i).items()}
        return cache[i]

    def inputs(i: int) -> dict[str, torch.Tensor | None]:
        if (past, future) == (0, 0):
            return dict(frame(i))
        frames = [frame(j) for j in range(i - past, i + future + 1)]
        return {k: torch.stack([f[k] for f in frames], dim=1) for k in frames[0]}

    h, w = seq.size
    probe = {k: v[..., :PROBE, :PROBE] for k, v in inputs(0).items()}
    with running(device, dtype):
        per_pixel = bytes_per_pixel(model, probe)
    side = tile_size(per_pixel, max_memory_mb, overlap)
    tiled = TiledModel(model, h, w, side, overlap)
    log.info("%d frames of %dx%d from %s: %s reads %s as %s; exposure x%.4g; %d tile(s) (%.0f bytes/pixel, "
             "cap %g MB)", len(seq), w, h, paths[0].parent, loaded.experiment,
             ",".join(sorted(want)) or "colour", key, seq.exposure, len(tiled), per_pixel, max_memory_mb)
    t0 = time.perf_counter()
    stateful = bool(getattr(model, "temporal_state", True))
    resumed: list[str] = []
    scorer = Scorer(references, seq.exposure, seq.bad) if references else None

    def summary() -> dict[str, Any]:
        return {**(meta or {}), "frames": len(seq), "tiles": len(tiled), "size": [h, w],
                "exposure": seq.exposure, "sanitised": seq.bad, "seconds": time.perf_counter() - t0,
                "out_dir": str(out_dir), "resumed": resumed,
                **({"scores": scorer.summary()} if scorer else {})}

    tiled.reset()
    bar = tqdm(range(len(seq)), desc="denoise", unit="frame", disable=not progress)
    with running(device, dtype):
        for i in bar:
            stem = paths[i].stem
            finished = record is not None and record.is_finished(stem, f"{stem}.exr")
            if not finished or stateful:
                out = tiled(inputs(i))
            if scorer is not None:
                denoised = (hwc(out["output"]) if not finished or stateful
                            else scale(read_exr(out_dir / f"{stem}.exr"), seq.exposure))
                scorer.score(i, stem, hwc(frame(i)[key]), denoised)
            if finished:
                resumed.append(stem)
                assert record is not None
                record.keep(stem)
            else:
                write_frame(out_dir, stem, out, seq.exposure)
                if record is not None:
                    record.done(stem, summary())
            for j in [j for j in cache if j < i - past]:
                del cache[j]
    if resumed:
        log.info("%d frame(s) finished by a previous run with the same settings, not written again: %s",
                 len(resumed), ", ".join(resumed))
    return summary()

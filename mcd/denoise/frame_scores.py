"""Scores of ``mcd-denoise`` on frames from disk against references (docs/denoise.md, "Scores of frames").

A frame's reference is the file of the same name in ``--reference DIR``, or, without the flag, in the folder
``reference/`` beside the frame (where ``python -m mcd.denoise.render_frames --reference-spp N`` writes
them): with the flag every frame must have one; without it, references are used only when every frame has
one (otherwise nothing is scored, and the log says how many were missing). A reference is checked as a frame
is, before any work (readable, colour channels ``R, G, B``, the frames' size); one whose every colour value is
NaN or Inf is refused then (there is nothing to score against). A reference's NaN/Inf/negative values that
remain are replaced by 0 as the input's are, counted in ``sanitised`` (``<file>:reference``) with a warning
naming the file, and the frame's score line says how many (``reference_sanitised``).

Input (the noisy colour as the network reads it), output and reference are compared in one exposure, the
sequence's (frame 0's mean scaled to the checkpoint's target, :mod:`mcd.data.exposure`), sanitised alike,
with :mod:`mcd.core.metrics`: PSNR and SSIM of the display images and mean LDR-FLIP. Per frame and the mean
over the frames are printed and recorded in ``denoise.json`` (``scores``).
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from mcd.core.metrics import SSIM_WINDOW, flip, psnr, ssim
from mcd.data.exposure import normalise
from mcd.denoise.frames import FrameError, read_frame

log = logging.getLogger(__name__)

#: The folder beside the frames where references are looked for without ``--reference``.
REFERENCE_FOLDER = "reference"
#: The metrics computed for the input and the output, in print order.
METRICS = ("psnr", "ssim", "flip")


def find_references(paths: list[Path], given: Path | None) -> list[Path] | None:
    """Each frame's reference (module docstring), or None when there is nothing to score against.

    FrameError naming the missing files when ``given`` (``--reference``) lacks some.
    """
    if given is not None:
        if not given.is_dir():
            raise FrameError(f"--reference {given}: not a folder; give the folder of the references, one EXR "
                             "per frame, named as the frames")
        refs = [given / p.name for p in paths]
        missing = [r for r in refs if not r.is_file()]
        if missing:
            more = ", ..." if len(missing) > 3 else ""
            raise FrameError(f"--reference {given}: no reference for {len(missing)} of {len(paths)} frames "
                             f"({', '.join(str(m) for m in missing[:3])}{more}); give one EXR per frame, "
                             "named as the frame")
        return refs
    refs = [p.parent / REFERENCE_FOLDER / p.name for p in paths]
    found = sum(r.is_file() for r in refs)
    if found and found < len(refs):
        log.warning("references beside the frames for %d of %d frames only: nothing is scored (give "
                    "--reference DIR with one per frame)", found, len(refs))
    return refs if found == len(refs) else None


def check_references(refs: list[Path], size: tuple[int, int]) -> None:
    """Every reference readable, with colour channels and the frames' ``size`` ``(H, W)``; FrameError naming
    the file. Frames below the SSIM window cannot be scored."""
    if min(size) < SSIM_WINDOW:
        raise FrameError(f"{refs[0]}: frames of {size[1]}x{size[0]} are below the SSIM window "
                         f"({SSIM_WINDOW}x{SSIM_WINDOW}) and cannot be scored; drop the references")
    for ref in refs:
        colour = read_frame(ref, set(), size)["colour"]
        if not np.isfinite(colour).any():
            raise FrameError(f"{ref}: every value of the reference is NaN or Inf, so there is nothing to "
                             "score against; render the reference again, or give no references")


class Scorer:
    """Scores of each frame against its reference, in the sequence's exposure (module docstring)."""

    def __init__(self, refs: list[Path], exposure: float, sanitised: dict[str, int]):
        self.refs, self.exposure, self.sanitised = refs, exposure, sanitised
        self.rows: list[dict[str, Any]] = []

    def score(self, i: int, stem: str, noisy: np.ndarray, output: np.ndarray) -> dict[str, Any]:
        """Score frame ``i`` (``noisy`` and ``output``: ``(H, W, 3)`` in the sequence's exposure)."""
        colour = read_frame(self.refs[i], set())["colour"]
        ref, n_bad = normalise(colour, "ref", self.exposure, 1.0, colour=True)
        row: dict[str, Any] = {"frame": stem, "reference": str(self.refs[i])}
        if n_bad:
            self.sanitised[f"{self.refs[i].name}:reference"] = n_bad
            row["reference_sanitised"] = n_bad
            log.warning("%s: %d NaN/Inf/negative values of the reference replaced by 0; the scores of %s are "
                        "against what remains", self.refs[i], n_bad, stem)
        for name, img in (("input", noisy), ("output", output)):
            row.update({f"psnr_{name}": psnr(img, ref), f"ssim_{name}": ssim(img, ref),
                        f"flip_{name}": flip(img, ref)})
        self.rows.append(row)
        return row

    def mean(self) -> dict[str, float]:
        """The mean of every score over the frames scored."""
        keys = [f"{m}_{w}" for w in ("input", "output") for m in METRICS]
        return {k: float(np.mean([r[k] for r in self.rows])) for k in keys}

    def summary(self) -> dict[str, Any]:
        """What ``denoise.json`` records under ``scores``."""
        return {"frames": self.rows, "mean": self.mean() if self.rows else {}, "exposure": self.exposure}


def score_text(row: dict[str, Any]) -> str:
    """``input PSNR .. dB, SSIM .., FLIP .. -> output PSNR ..``: one line's scores, and how many of the
    reference's values were replaced by 0 where some were."""
    text = " -> ".join(f"{w} PSNR {row[f'psnr_{w}']:.2f} dB, SSIM {row[f'ssim_{w}']:.4f}, FLIP "
                       f"{row[f'flip_{w}']:.4f}" for w in ("input", "output"))
    bad = row.get("reference_sanitised")
    return f"{text} (reference: {bad} NaN/Inf/negative values replaced by 0)" if bad else text

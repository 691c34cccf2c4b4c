"""Resuming ``mcd-denoise`` on frames: which frames a previous run into the same folder finished with the same
settings (docs/denoise.md, "Output"; docs/reliability.md, "Denoising your frames").

``<out>/denoise.json`` is rewritten (atomically) after every frame with ``settings`` (what the outputs depend
on: the input files with their sizes and modification times, the weights' SHA-256, the experiment, budget,
precision, device, tile cap and overlap) and ``finished`` (the stems whose every file is written). A rerun
with equal ``settings`` skips a finished frame whose EXR is still there; any other difference (or no record)
denoises every frame again, naming the settings that changed. A method with temporal state still runs every
frame (its state needs them), writing only the missing ones.
"""

from __future__ import annotations

import hashlib
import json
import logging
from pathlib import Path
from typing import Any

import torch
from torch import nn

from mcd.denoise.output import SUMMARY, write_json

log = logging.getLogger(__name__)


def weights_digest(model: nn.Module) -> str:
    """SHA-256 of the model's parameters and buffers (names, shapes and bytes), in name order."""
    h = hashlib.sha256()
    for name, t in sorted(model.state_dict().items()):
        h.update(f"{name}:{tuple(t.shape)}:{t.dtype}".encode())
        h.update(t.detach().cpu().reshape(-1).contiguous().view(torch.uint8).numpy().tobytes())
    return h.hexdigest()


def file_stamps(paths: list[Path]) -> list[list[Any]]:
    """``[resolved path, bytes, mtime_ns]`` of each file: enough to tell that an input changed."""
    out = []
    for p in paths:
        st = p.stat()
        out.append([str(p.resolve()), st.st_size, st.st_mtime_ns])
    return out


class Record:
    """The finished frames of this run in ``<out>/denoise.json``, and those a previous run left (module
    docstring)."""

    def __init__(self, out_dir: Path, settings: dict[str, Any]):
        self.path = out_dir / SUMMARY
        self.out_dir = out_dir
        self.settings = json.loads(json.dumps(settings, default=str))    # as it reads back from the JSON
        self.finished: list[str] = []
        self.previous: set[str] = set()
        if self.path.is_file():
            try:
                old = json.loads(self.path.read_text())
            except (OSError, ValueError):
                old = {}
            old_settings = old.get("settings") if isinstance(old, dict) else None
            if old_settings == self.settings:
                self.previous = {str(s) for s in old.get("finished", [])}
            else:
                changed = sorted(k for k in {*self.settings, *(old_settings or {})}
                                 if (old_settings or {}).get(k) != self.settings.get(k))
                log.info("%s: made with other settings (%s): denoising every frame again", self.path,
                         ", ".join(changed) or "no record")

    def is_finished(self, stem: str, exr_name: str) -> bool:
        """Whether a previous run with these settings finished ``stem`` and its EXR ``exr_name`` is there."""
        return stem in self.previous and (self.out_dir / exr_name).is_file()

    def keep(self, stem: str) -> None:
        """Record ``stem`` as finished by the previous run (kept, not written again)."""
        self.finished.append(stem)

    def done(self, stem: str, summary: dict[str, Any]) -> None:
        """Record ``stem`` as finished; rewrite the JSON with ``summary`` (the run's figures so far)."""
        self.finished.append(stem)
        self.write(summary, complete=False)

    def write(self, summary: dict[str, Any], complete: bool) -> None:
        write_json(self.path, {**summary, "complete": complete, "settings": self.settings,
                               "finished": self.finished})

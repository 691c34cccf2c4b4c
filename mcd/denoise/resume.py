"""Resuming ``mcd-denoise`` on frames: which frames a previous run into the same folder finished with the same
settings (docs/denoise.md, "Output"; docs/reliability.md, "Denoising your frames").

``<out>/denoise.json`` is rewritten (atomically) after every frame with ``settings`` (what the outputs depend
on: the input files with their sizes, modification times and SHA-256, the weights' and the configuration's
SHA-256, the experiment,
budget, precision, device, tile cap and overlap), ``finished`` (the stems whose every file is written) and
``checksums`` (the SHA-256 of each of those files). A rerun with equal ``settings`` skips a finished frame
whose files are all there with their recorded SHA-256 (one emptied or replaced since is denoised again); any
other difference (or no record) denoises every frame again, naming the settings that changed. A method with
temporal state still runs every frame (its state needs them), writing only the missing ones. A record that
is damaged (not a JSON object, or ``settings``, ``finished`` or ``checksums`` of another type) is refused
before any frame is denoised, naming the file and the fix (:class:`RecordError`).
"""

from __future__ import annotations

import hashlib
import json
import logging
from pathlib import Path
from typing import Any

import torch
from torch import nn

from mcd.data.exr import sha256
from mcd.denoise.output import SUMMARY, frame_files, write_json

log = logging.getLogger(__name__)


def weights_digest(model: nn.Module) -> str:
    """SHA-256 of the model's parameters and buffers (names, shapes and bytes), in name order."""
    h = hashlib.sha256()
    for name, t in sorted(model.state_dict().items()):
        h.update(f"{name}:{tuple(t.shape)}:{t.dtype}".encode())
        h.update(t.detach().cpu().reshape(-1).contiguous().view(torch.uint8).numpy().tobytes())
    return h.hexdigest()


def config_digest(cfg: Any) -> str:
    """SHA-256 of the configuration the model is built and fed with (a checkpoint's, or a bundle's JSON): the
    same weights under another configuration (``data.exposure_target``, which sets the input exposure) give
    other outputs, and a resume compared the weights alone."""
    from omegaconf import OmegaConf

    plain = OmegaConf.to_container(cfg, resolve=False) if OmegaConf.is_config(cfg) else cfg
    return hashlib.sha256(json.dumps(plain, sort_keys=True, default=str).encode()).hexdigest()


def file_stamps(paths: list[Path]) -> list[list[Any]]:
    """``[resolved path, bytes, mtime_ns, SHA-256]`` of each file. The size and time alone did not tell
    that an input changed: a frame replaced by another of the same size with the same time (a copy that
    keeps times, an archive's fixed times, a file system's coarse clock) kept the old frame's output."""
    out = []
    for p in paths:
        st = p.stat()
        out.append([str(p.resolve()), st.st_size, st.st_mtime_ns, sha256(p)])
    return out


class RecordError(ValueError):
    """``<out>/denoise.json`` is damaged; the message names the file and what to do."""


#: The type of each field of ``denoise.json`` that resuming reads (a field may be absent: no record).
RECORD_TYPES = {"settings": dict, "finished": list, "checksums": dict}
#: Every ``denoise.json`` that ``mcd-denoise`` writes holds one of these fields: ``complete`` (the first
#: record, written before any output, and every record of frames mode) or ``out_dir`` (the summary of a
#: finished run, either mode). A JSON object with neither is another program's file, which a run must not
#: replace.
OWN_FIELDS = ("complete", "out_dir")


def read_record(path: Path) -> dict[str, Any]:
    """The previous run's ``denoise.json`` at ``path``; RecordError naming it and the fix when it is not a
    JSON object, a field of :data:`RECORD_TYPES` has another type, or it holds none of :data:`OWN_FIELDS` (a
    user's own ``denoise.json`` in ``-o`` was replaced, and the files named like outputs beside it
    overwritten)."""
    try:
        old = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        why = f"not readable JSON: {type(err).__name__}"
    else:
        if isinstance(old, dict) and not any(k in old for k in OWN_FIELDS):
            raise RecordError(f"{path}: not a record of mcd-denoise (a JSON object without its fields "
                              f"{' or '.join(OWN_FIELDS)}: another program's file?); it is kept as it "
                              "is, and so is every file beside it: give another -o")
        bad = ([f"{k} is a JSON {type(old[k]).__name__}, not {t.__name__}" for k, t in RECORD_TYPES.items()
                if k in old and not isinstance(old[k], t)] if isinstance(old, dict)
               else [f"a JSON {type(old).__name__}, not an object"])
        if not bad:
            return old
        why = "; ".join(bad)
    raise RecordError(f"{path}: not a record of mcd-denoise ({why}); delete it to denoise every frame again, "
                      "or give another -o")


def check_kind(path: Path, scene: bool) -> None:
    """RecordError where the earlier ``denoise.json`` at ``path`` is the record of the other input: a
    ``--scene`` run's (``variant``, no ``settings``: its samples, exposures and scores) for a frames run, or
    a frames run's (``settings``) for a ``--scene`` run. Either replaced it, and its outputs stayed beside
    the new ones without a record (the scene run's scores were lost without a word)."""
    if not path.is_file():
        return
    old = read_record(path)
    earlier_scene = "settings" not in old and "variant" in old
    if earlier_scene == scene or "settings" not in old and not earlier_scene:
        return
    kind = "an mcd-denoise --scene run" if earlier_scene else "an mcd-denoise run on frames"
    raise RecordError(f"{path}: the record of {kind}, whose outputs are beside it; this run would replace "
                      "the record and leave them unrecorded: give another -o (or delete the folder's files)")


def _in_folder(name: object) -> bool:
    """Whether a file name read from a record names a file in the record's own folder: a plain name, no
    ``/`` and not ``.`` or ``..`` (a crafted record's ``../x`` was named to the user as an output to
    delete)."""
    return isinstance(name, str) and name not in ("", ".", "..") and Path(name).name == name


def recorded_outputs(old: dict[str, Any]) -> set[str]:
    """The output files an earlier ``denoise.json`` (read by :func:`read_record`) says its run wrote: a
    frames run's ``checksums`` (every file of each finished frame), a ``--scene`` run's ``outputs``; none for
    a record from before ``outputs`` or one with no finished frame. Names that leave the record's folder are
    not taken (:func:`_in_folder`)."""
    sums = old.get("checksums")
    names = {n for files in sums.values() if isinstance(files, dict) for n in files} \
        if isinstance(sums, dict) else set()
    outputs = old.get("outputs")
    names |= set(outputs) if isinstance(outputs, list) else set()
    return {n for n in names if _in_folder(n)}


def check_earlier_outputs(path: Path, outputs: list[str]) -> None:
    """RecordError where the earlier record at ``path`` lists output files that are still in its folder and
    that this run, whose file names are ``outputs``, does not write: another sequence or scene, or fewer
    frames, into a finished ``-o`` replaced the record (its scores, its checksums) and left those outputs
    beside the new ones unrecorded, exit 0. A rerun over the same frames (or more) goes on as before."""
    if not path.is_file():
        return
    mine = set(outputs)
    left = sorted(n for n in recorded_outputs(read_record(path)) - mine if (path.parent / n).is_file())
    if left:
        listed = ", ".join(left[:3]) + (f" and {len(left) - 3} more" if len(left) > 3 else "")
        raise RecordError(f"{path.parent}: holds {listed}, outputs of an earlier run that {path.name} "
                          "records and this run does not write (other frames, another scene, or fewer "
                          "frames); this run would replace the record and leave them unrecorded: give "
                          "another -o, or delete them (and its denoise.json) first")


class Record:
    """The finished frames of this run in ``<out>/denoise.json``, and those a previous run left (module
    docstring)."""

    def __init__(self, out_dir: Path, settings: dict[str, Any]):
        self.path = out_dir / SUMMARY
        self.out_dir = out_dir
        self.settings = json.loads(json.dumps(settings, default=str))    # as it reads back from the JSON
        self.finished: list[str] = []
        #: SHA-256 of each output file of each finished frame (this run's, and those a previous run left)
        self.checksums: dict[str, dict[str, str]] = {}
        self.previous: dict[str, dict[str, str]] = {}
        if self.path.is_file():
            old = read_record(self.path)
            old_settings = old.get("settings")
            if old_settings == self.settings:
                sums = old.get("checksums")
                sums = sums if isinstance(sums, dict) else {}
                self.previous = {s: sums[s] for s in old.get("finished", [])
                                 if isinstance(s, str) and isinstance(sums.get(s), dict) and sums[s]
                                 and all(n in frame_files(s) for n in sums[s])}  # its own files only
            else:
                changed = sorted(k for k in {*self.settings, *(old_settings or {})}
                                 if (old_settings or {}).get(k) != self.settings.get(k))
                log.info("%s: made with other settings (%s): denoising every frame again", self.path,
                         ", ".join(changed) or "no record")

    def is_finished(self, stem: str, exr_name: str) -> bool:
        """Whether a previous run with these settings finished ``stem``, and every file it wrote for it (the
        EXR ``exr_name`` among them) is there with the SHA-256 it was recorded with: an output emptied,
        truncated or replaced since is denoised again, never kept."""
        sums = self.previous.get(stem)
        if not sums or exr_name not in sums:
            return False
        for name, digest in sums.items():
            path = self.out_dir / name
            if not path.is_file() or sha256(path) != digest:
                log.warning("%s: not as the previous run wrote it (missing or other bytes): denoising frame "
                            "%s again", path, stem)
                return False
        return True

    def keep(self, stem: str) -> None:
        """Record ``stem`` as finished by the previous run (kept, not written again)."""
        self.finished.append(stem)
        self.checksums[stem] = self.previous[stem]

    def done(self, stem: str, summary: dict[str, Any]) -> None:
        """Record ``stem`` as finished with the SHA-256 of each file written for it; rewrite the JSON with
        ``summary`` (the run's figures so far)."""
        self.finished.append(stem)
        self.checksums[stem] = {name: sha256(self.out_dir / name) for name in frame_files(stem)
                                if (self.out_dir / name).is_file()}
        self.write(summary, complete=False)

    def write(self, summary: dict[str, Any], complete: bool) -> None:
        write_json(self.path, {**summary, "complete": complete, "settings": self.settings,
                               "finished": self.finished, "checksums": self.checksums})

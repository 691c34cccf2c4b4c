"""The output folder ``-o`` of ``mcd-denoise``, checked before any work (docs/denoise.md, "Output";
docs/reliability.md, "Denoising your frames").

Nothing a user gives is lost: the folder must be a folder that can be made and written to, must not be the
folder of an input file, must not contain an input (at any depth, symlinks resolved both ways), and no file
the run would write may be an input or a symlink, and a folder without a ``denoise.json`` (no ``mcd-denoise``
run wrote there) must hold no file named like an output (:func:`check_unrecorded`: a user's own files were
overwritten). An output folder inside an input folder is allowed: frames are read from a folder's own
``*.exr``, never from its subfolders. One run at a time writes into a folder
(:func:`hold`): a second ``mcd-denoise`` on the same ``-o`` is refused before it writes anything.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from mcd.core import file_lock
from mcd.core.atomic_write import atomic_write_json
from mcd.core.paths import free_space


class OutputFolderError(ValueError):
    """``-o`` cannot take this run's outputs; the message names the folder, the file and what to do."""


def _location(path: Path) -> set[Path]:
    """Where ``path`` is: its folder resolved with its own name, and (for a symlink) its target."""
    return {path.absolute().parent.resolve() / path.name, path.resolve()}


def check_writable(out: Path) -> None:
    """Make ``out`` (and its parents) and write a temporary file in it; OutputFolderError naming what is in
    the way (a file where a folder is needed, no permission, a read-only file system)."""
    if out.exists() and not out.is_dir():
        raise OutputFolderError(f"-o {out}: is a file, not a folder; give a folder for the outputs")
    for parent in out.absolute().parents:
        if parent.exists():
            if not parent.is_dir():
                raise OutputFolderError(f"-o {out}: {parent} is a file, so the folder cannot be made inside "
                                        "it; give a folder whose parents are folders")
            break
    try:
        out.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(dir=out, prefix=".write-probe.")
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise OutputFolderError(f"-o {out}: cannot write there ({exc.strerror or exc}); give a writable "
                                "folder") from exc


@contextlib.contextmanager
def hold(out: Path) -> Iterator[None]:
    """Hold an exclusive lock on the folder ``out`` (made by :func:`check_writable`) while the block runs:
    OutputFolderError at once if another ``mcd-denoise`` holds it, so two runs never mix their outputs and
    ``denoise.json``. The kernel drops the lock when its holder dies."""
    with file_lock.exclusive_folder(out) as held:
        if not held:
            raise OutputFolderError(f"-o {out}: another mcd-denoise is writing into this folder; wait for it "
                                    "to finish, or give another folder")
        yield


def check_apart(out: Path, inputs: Iterable[Path], outputs: Iterable[str]) -> None:
    """Refuse ``out`` when it is the folder of an input, contains an input, or when one of the file names
    ``outputs`` (written in ``out``) is an input or a symlink (module docstring)."""
    root = out.absolute().resolve()
    taken: dict[Path, Path] = {}
    for f in inputs:
        for loc in _location(f):
            taken[loc] = f
            if loc.parent == root:
                raise OutputFolderError(
                    f"-o {out}: is the folder of the input {f}; the outputs would be written among (and "
                    "over) the inputs. Give another folder for the outputs")
            if root in loc.parents:
                raise OutputFolderError(
                    f"-o {out}: contains the input {f}; give an output folder that holds no input")
    for name in outputs:
        target = out / name
        if target.is_symlink():
            raise OutputFolderError(
                f"{target}: a symlink named like an output of this run (to {os.readlink(target)}); outputs "
                "are never written through a link. Remove it, or give another -o")
        if root / name in taken:
            raise OutputFolderError(f"{target}: is the input {taken[root / name]}; give another -o")


def check_unrecorded(out: Path, record: str, outputs: Iterable[str]) -> None:
    """Refuse ``out`` when it has no ``record`` (``denoise.json``: no ``mcd-denoise`` run wrote there) and yet
    holds files named like this run's ``outputs``: they are someone's own files, which the run would
    overwrite. :func:`claim` writes the record before the first output, so a stopped run's folder passes."""
    if (out / record).exists():
        return
    found = [name for name in outputs if (out / name).exists()]
    if found:
        listed = ", ".join(found[:3]) + (f" and {len(found) - 3} more" if len(found) > 3 else "")
        raise OutputFolderError(
            f"-o {out}: holds {listed}, named like outputs of this run, and no {record}, so no mcd-denoise "
            "run wrote them; they would be overwritten. Move them, or give another -o")


def claim(out: Path, record: str) -> None:
    """Write a first ``record`` (``denoise.json``, not complete) into ``out`` where there is none, before the
    first output: the folder is then known as ``mcd-denoise``'s (:func:`check_unrecorded`)."""
    if not (out / record).exists():
        atomic_write_json(out / record, {"complete": False})


#: Bytes one output file of a frame of one pixel takes at most (a float32 RGB EXR without compression), and
#: what each file takes beside its pixels (headers, the PNG's own, a margin).
BYTES_PER_PIXEL = 12
BYTES_PER_FILE = 65536


def check_space(out: Path, outputs: list[str], pixels: int) -> None:
    """OutputFolderError, before any work, where the disk of ``out`` has less free space than ``outputs``
    (files that every method writes and that are still to write, each of a frame of ``pixels``) take at
    most: a disk that filled half-way stopped the run on an OSError traceback after the frames before. A
    method's extra outputs (F's maps) are not counted, so a run that may fit is never refused; a disk that
    fills all the same ends in one error line (``mcd.denoise.cli``), and a rerun resumes."""
    if not outputs:
        return
    need = len(outputs) * (pixels * BYTES_PER_PIXEL + BYTES_PER_FILE)
    where, free = free_space(out)
    if free < need:
        raise OutputFolderError(f"-o {out}: the {len(outputs)} output file(s) still to write need up to "
                                f"{need / 1e6:.1f} MB and its disk ({where}) has {free / 1e6:.1f} MB free; "
                                "free space there, or give an -o on a disk with room")

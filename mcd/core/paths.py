"""Where files are, resolved in one place (docs/architecture.md, "Layers"): the package's own files (the
Hydra config folder and the vendored scenes, both inside the package so that an installed wheel has them, and
the checkout), and the configured folders of the ``paths`` config group (``conf/paths/default.yaml``:
``paths.data_dir``, ``paths.scenes_dir``), checked before any work so that a missing one is named with its
key.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
from collections.abc import Callable
from pathlib import Path

#: A name that becomes one folder under an output root (a store's profile or scene, a report, a bundle):
#: letters, digits, ``_``, ``-``, ``.`` (not leading), so never ``/``, ``..`` or a hidden name.
SAFE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.-]*")

#: The ``mcd`` package folder.
PACKAGE_DIR = Path(__file__).resolve().parents[1]
#: The checkout the package was imported from (in an installed package: the folder above it, which holds no
#: checkout; :func:`mcd.core.provenance.git_commit` then says ``unknown``).
REPO_ROOT = PACKAGE_DIR.parent
#: The Hydra config folder (``conf/config.yaml`` and its groups), package data (``conf`` at the repository
#: root is a link to it).
CONF_DIR = PACKAGE_DIR / "conf"
#: The small scenes vendored with the code (docs/scenes.md), package data (``scenes`` at the repository root
#: is a link to it).
VENDORED_SCENES_DIR = PACKAGE_DIR / "scenes"


def data_dir(value: str | Path | None) -> Path:
    """The data store's folder from ``paths.data_dir`` (conf/paths/default.yaml; env ``MCD_DATA_DIR``).

    It may not exist yet (the first render makes it); ValueError naming the key if it is empty or names a
    file, before any work starts.
    """
    if value is None or not str(value).strip():
        raise ValueError("paths.data_dir is empty: give the data store's folder (paths.data_dir=<dir> or the "
                         "environment variable MCD_DATA_DIR; default ./data)")
    path = Path(value).expanduser()
    if path.exists() and not path.is_dir():
        raise ValueError(f"paths.data_dir={value} (or MCD_DATA_DIR) is a file, not a folder: give the data "
                         "store's folder (docs/data.md)")
    return path


def folder_to_be(key: str, path: Path) -> Path:
    """``path``, a folder that ``key`` names and a command may make: ValueError naming the key and the file
    when ``path`` or a folder above it is a file (its ``mkdir`` would fail with a bare FileExistsError or
    NotADirectoryError), before any work starts."""
    for at in (path, *path.parents):
        if at.exists() or at.is_symlink():
            if not at.is_dir():
                where = "is a file" if at == path else f"lies below {at}, which is a file"
                raise ValueError(f"{key}={path} {where}, not a folder: give a folder (one that does not "
                                 "exist yet is made)")
            return path
    return path


def writable_folder_to_be(key: str, path: Path) -> Path:
    """``path``, a folder that ``key`` names and a command writes into: :func:`folder_to_be`, and ValueError
    naming the key and the folder when the nearest existing folder at or above ``path`` cannot be written
    (a read-only mount, or no write permission), before any work starts."""
    folder_to_be(key, path)
    at = next(p for p in (path, *path.parents) if p.exists())
    if not os.access(at, os.W_OK | os.X_OK):
        where = "is" if at == path else f"would be made in {at}, which is"
        raise ValueError(f"{key}={path} {where} not writable (a read-only mount, or no permission): give a "
                         "folder this user can write")
    return path


def writable_file_to_be(key: str, path: Path) -> Path:
    """``path``, a file that ``key`` names and a command writes at its end: ValueError naming the key when it
    is a folder, or its folder cannot be made or written (:func:`writable_folder_to_be`), before any work
    starts (a measurement of minutes ended in an IsADirectoryError traceback where ``--out`` named a
    folder). An existing path that is not a regular file (a FIFO, a device such as ``/dev/null``, a socket) is
    refused too: with a FIFO the measurement ran, then waited for ever for a reader."""
    if path.is_dir():
        raise ValueError(f"{key}={path} is a folder, not a file: give a file name (in that folder, say)")
    if path.exists() and not path.is_file():
        raise ValueError(f"{key}={path} is not a regular file (a FIFO, a device or a socket): give a file "
                         "name in a folder")
    writable_folder_to_be(key, path.parent)
    return path


def _argparse_type(check: Callable[[str, Path], Path], key: str) -> Callable[[str], Path]:
    """``check(key, path)`` as an argparse ``type``: its ValueError becomes the parser's error (exit 2)."""

    def parse(text: str) -> Path:
        try:
            return check(key, Path(text))
        except ValueError as err:
            raise argparse.ArgumentTypeError(str(err)) from None

    return parse


def writable_file_arg(key: str) -> Callable[[str], Path]:
    """The argparse ``type`` of option ``key`` (``--out``) that names a file the command writes at its end:
    :func:`writable_file_to_be` at parse time, so that the parser's error (exit 2, naming ``key``) comes
    before any measurement. argparse applies it to a default given as a string too."""

    return _argparse_type(writable_file_to_be, key)


def writable_folder_arg(key: str) -> Callable[[str], Path]:
    """The argparse ``type`` of option ``key`` (``--dir``) that names a folder the command writes into:
    :func:`writable_folder_to_be` at parse time, so that a file there is the parser's error (exit 2, naming
    ``key``), not a traceback naming the key of a config made from it."""

    return _argparse_type(writable_folder_to_be, key)


def scenes_dir(value: str | Path | None) -> Path | None:
    """The folder of the scenes not vendored in ``scenes/`` from ``paths.scenes_dir`` (env ``MCD_SCENES_DIR``;
    docs/scenes.md), or ``None`` when unset (then only those scenes fail, each naming the key).

    A relative path is taken from the working directory, else from the checkout. ValueError naming the key
    and what to do if it is set and no such folder exists, before any work starts.
    """
    if value is None or not str(value).strip():
        return None
    path = Path(value).expanduser()
    if not path.is_absolute() and not path.exists():
        path = REPO_ROOT / path
    if not path.is_dir():
        raise ValueError(f"paths.scenes_dir={value} (or MCD_SCENES_DIR): no such folder; set it to the "
                         "folder that holds the scenes not vendored in scenes/ (docs/scenes.md says where to "
                         "get each), or unset it to use the vendored scenes only")
    return path


class UnsafeNameError(ValueError):
    """A name that would become a folder is not one plain folder name (:func:`check_folder_name`)."""


def check_folder_name(name: object, key: str, why: str) -> str:
    """``name`` if it is one plain folder name (:data:`SAFE_NAME`), else UnsafeNameError naming ``key``
    (where the name came from: an override, a flag, or a field and the file holding it) and ``why`` (which
    folder it becomes). The one rule for names that become folders, so that a name from data or a command
    line never writes outside its output root (docs/reliability.md)."""
    if not isinstance(name, str) or not SAFE_NAME.fullmatch(name):
        raise UnsafeNameError(f"{key}={name!r}: not a plain folder name (letters, digits, '_', '-', '.', not "
                              f"leading '.'); {why}, so a name must not hold '/' or '..'")
    return name


def free_space(path: Path) -> tuple[Path, int]:
    """``(where, bytes)``: the free space of the disk that ``path`` is, or will be made, on, read at its
    nearest existing folder (``where``, named in the callers' messages). The one free-space reading of the
    checks that run before a write (the training store's pack, ``mcd-denoise``'s outputs)."""
    where = next(p for p in (path, *path.parents) if p.exists())
    return where, shutil.disk_usage(where).free

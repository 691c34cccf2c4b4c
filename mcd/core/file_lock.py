"""One exclusive advisory lock (``fcntl.flock``) on a file, for every writer that must be alone on a path: the
run directory's ``run.lock`` (:mod:`mcd.lit.run_dir`; docs/reliability.md, "One owner per run directory"),
the EXR store's scene and frame locks (:mod:`mcd.data.store_builder`; docs/architecture.md, "The store") and
the training store's packer lock per scene (:mod:`mcd.data.pack`; docs/training_store.md); and, with
:func:`exclusive_folder`, on a folder itself (``mcd-denoise``'s ``-o``, :mod:`mcd.denoise.output_folder`),
which adds no file among its outputs.

The kernel drops a ``flock`` when its holder dies, so a killed process never leaves a stale lock behind. The
lock file is made if missing and never truncated or removed here: a holder may keep notes in it (``run.lock``
holds its owner's pid and host). A lock file is never a symbolic link: one is refused
(:class:`LinkedLockError`) instead of followed, so that a link placed at a lock's name (dangling, or to a
user's file) makes or touches nothing where it points.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
from collections.abc import Iterator
from pathlib import Path
from typing import TextIO


class LinkedLockError(RuntimeError):
    """A lock file that is a symbolic link; the message names it, where it points, and the fix."""


def _open_lock(path: Path) -> TextIO:
    """``path`` opened ``a+``, made if missing, never through a symbolic link (``O_NOFOLLOW``)."""
    try:
        fd = os.open(path, os.O_RDWR | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW, 0o666)
    except OSError as err:
        if not path.is_symlink():
            raise
        raise LinkedLockError(f"{path}: this lock file is a symbolic link (to {os.readlink(path)}); a lock "
                              "is taken on a file of its own, never through a link: remove the link (`rm "
                              f"{path}`) and run again") from err
    return os.fdopen(fd, "a+")


@contextlib.contextmanager
def exclusive(path: Path, *, blocking: bool = True) -> Iterator[TextIO | None]:
    """Hold an exclusive ``flock`` on ``path`` while the block runs, and yield the lock file (opened ``a+``,
    for a holder that keeps notes in it).

    ``blocking=True`` waits for the lock. ``blocking=False`` yields ``None`` at once, holding nothing, when
    another holder has it (another process, or another ``open`` of the file in this one). The parent
    directory is made if missing; callers check that ``path`` is a regular file where they want a refusal
    that names their own fix (``open`` fails on a directory); a symbolic link is :class:`LinkedLockError`.
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    with _open_lock(path) as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | (0 if blocking else fcntl.LOCK_NB))
        except BlockingIOError:
            held = False
        else:
            held = True
        if not held:  # yielded outside the except clause: the block's own errors carry no BlockingIOError
            yield None
            return
        try:
            yield f
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def held_elsewhere(path: Path) -> bool:
    """Whether another open file holds an exclusive ``flock`` on ``path`` now (False where ``path`` is not a
    regular file). Probes with a shared lock, taken and dropped at once, and creates nothing."""
    if not path.is_file():
        return False
    try:
        with open(path, "rb") as f:
            fcntl.flock(f, fcntl.LOCK_SH | fcntl.LOCK_NB)  # dropped when f closes
    except BlockingIOError:
        return True
    except OSError:  # unreadable: nothing to say about its holder
        return False
    return False


def folder_held_elsewhere(path: Path) -> bool:
    """Whether another open descriptor holds an exclusive ``flock`` on the folder ``path`` now
    (:func:`exclusive_folder`'s lock; False where ``path`` is not a folder). Probes with a shared lock, taken
    and dropped at once."""
    if not path.is_dir():
        return False
    try:
        fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(fd)  # drops the probe's lock
    return False


@contextlib.contextmanager
def exclusive_folder(path: Path) -> Iterator[bool]:
    """Try an exclusive ``flock`` on the folder ``path`` itself (an ``O_DIRECTORY`` descriptor) while the
    block runs; yield whether it is held (False at once when another holder has it). No lock file is made."""
    fd = os.open(path, os.O_RDONLY | os.O_DIRECTORY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            held = False
        else:
            held = True
        yield held
    finally:
        os.close(fd)  # drops the lock

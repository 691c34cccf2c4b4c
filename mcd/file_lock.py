"""One exclusive advisory lock (``fcntl.flock``) on a file, for every writer that must be alone on a path: the
run directory's ``run.lock`` (:mod:`mcd.run_dir`; docs/reliability.md, "One owner per run directory"), the EXR
store's scene and frame locks (:mod:`mcd.data.store_builder`; docs/architecture.md, "The store") and the
training store's packer lock per scene (:mod:`mcd.data.pack`; docs/training_store.md).

The kernel drops a ``flock`` when its holder dies, so a killed process never leaves a stale lock behind. The
lock file is made if missing and never truncated or removed here: a holder may keep notes in it (``run.lock``
holds its owner's pid and host).
"""

from __future__ import annotations

import contextlib
import fcntl
from collections.abc import Iterator
from pathlib import Path
from typing import TextIO


@contextlib.contextmanager
def exclusive(path: Path, *, blocking: bool = True) -> Iterator[TextIO | None]:
    """Hold an exclusive ``flock`` on ``path`` while the block runs, and yield the lock file (opened ``a+``,
    for a holder that keeps notes in it).

    ``blocking=True`` waits for the lock. ``blocking=False`` yields ``None`` at once, holding nothing, when
    another holder has it (another process, or another ``open`` of the file in this one). The parent
    directory is made if missing; callers check that ``path`` is a regular file where they want a refusal
    that names their own fix (``open`` fails on a directory).
    """
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a+") as f:
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

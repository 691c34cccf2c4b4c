"""One owner per run directory: a unique default directory, and an exclusive lock held while a run uses it
(docs/architecture.md, "Run directory"; docs/reliability.md, "One owner per run directory").

- :func:`register_resolvers` adds ``${run_id:}`` to OmegaConf: a short token drawn once per process (6 hex
  digits), which ``conf/config.yaml`` appends to the default ``hydra.run.dir``, so two runs started in the
  same second get two directories (and an ad-hoc ``-m`` sweep's). ``mcd.lit.hydra_callbacks`` calls it at
  import: Hydra instantiates the callbacks of ``conf/config.yaml`` before it resolves those directories, so
  every command composing that config has it.
- :func:`hold` takes ``<run dir>/run.lock`` with ``fcntl.flock`` (:func:`mcd.core.file_lock.exclusive`) for as
  long as the run lives; a second process on the same directory (two ``ckpt_path=auto`` resumes, a
  ``hydra.run.dir`` given twice, two copies of one sweep) is refused with :class:`RunDirInUse`, naming the
  owner's pid. The kernel drops the lock when the owner dies, so a killed run never leaves a stale lock
  behind.
- A finished run (a complete ``metrics.json``) is never written again: a rerun into its directory is skipped,
  or refused when it is another job's, without taking the lock or writing ``error.json``
  (:func:`mcd.run.main`), and ``conf/config.yaml`` sets Hydra's ``output_subdir`` and job log file through
  :func:`record_subdir` and :func:`run_log`, so that Hydra's own files stay as the run left them too.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import socket
import time
from collections.abc import Iterator
from pathlib import Path

from mcd.core import file_lock

#: The lock file inside a run directory.
LOCK_NAME = "run.lock"
_RUN_ID = secrets.token_hex(3)


class RunDirInUse(RuntimeError):
    """Another live process holds the run directory's lock."""


def run_id() -> str:
    """This process's token of ``${run_id:}`` (the same for every call in one process)."""
    return _RUN_ID


def is_finished(run_dir: str | Path) -> bool:
    """Whether ``run_dir`` holds a finished run (a complete ``metrics.json``,
    :func:`mcd.lit.run_record.is_complete`): its records are never written again."""
    from mcd.lit.run_record import is_complete

    return is_complete(Path(run_dir) / "metrics.json")


def in_use(run_dir: str | Path) -> bool:
    """Whether a live process holds ``run_dir``'s lock (:func:`hold`) now."""
    return file_lock.held_elsewhere(Path(run_dir) / LOCK_NAME)


def record_subdir(run_dir: str) -> str | None:
    """``hydra.output_subdir`` (``conf/config.yaml``): ``.hydra``, or None where ``run_dir`` holds a finished
    run or one that a live process holds (:func:`in_use`), so that Hydra, which saves its ``config.yaml``,
    ``hydra.yaml`` and ``overrides.yaml`` there before any of our code runs, leaves that run's files as they
    are (a rerun is skipped or refused; a second process is refused by :func:`hold`, and its Hydra files
    replaced the live run's, which the report then read as that run's config)."""
    return None if is_finished(run_dir) or in_use(run_dir) else ".hydra"


def run_log(run_dir: str, job_name: str) -> str:
    """The file of Hydra's job log (``hydra.job_logging.handlers.file.filename``): ``<run dir>/<job>.log``, or
    ``os.devnull`` where ``run_dir`` holds a finished run (its log is one of its records)."""
    return os.devnull if is_finished(run_dir) else str(Path(run_dir) / f"{job_name}.log")


def register_resolvers() -> None:
    """Register ``${run_id:}``, ``${record_subdir:dir}`` and ``${run_log:dir,job}`` with OmegaConf
    (idempotent)."""
    from omegaconf import OmegaConf

    for name, resolver in (("run_id", run_id), ("record_subdir", record_subdir), ("run_log", run_log)):
        if not OmegaConf.has_resolver(name):
            OmegaConf.register_new_resolver(name, resolver)


@contextlib.contextmanager
def hold(run_dir: Path) -> Iterator[None]:
    """Hold ``run_dir/run.lock`` exclusively while the block runs; :class:`RunDirInUse` at once if another
    process holds it (its pid, host and start time, as it wrote them into the file, are in the message).

    The directory is made if missing. A ``run.lock`` that is not a regular file is refused naming it.
    """
    run_dir.mkdir(parents=True, exist_ok=True)
    path = run_dir / LOCK_NAME
    if path.exists() and not path.is_file():
        raise RunDirInUse(f"{path} is not a regular file: remove it (the run directory's lock file, "
                          "docs/reliability.md) and start the run again")
    with file_lock.exclusive(path, blocking=False) as f:
        if f is None:
            owner = path.read_text().strip() or "pid unknown"
            raise RunDirInUse(
                f"{run_dir} is in use by another run ({owner}); wait for it to finish, or give this run its "
                "own directory (hydra.run.dir=<dir>, or sweep_tag=<tag> in a sweep)")
        f.seek(0)
        f.truncate()
        f.write(f"pid {os.getpid()} on {socket.gethostname()}, since "
                f"{time.strftime('%Y-%m-%d %H:%M:%S')}\n")
        f.flush()
        yield

"""Hydra callbacks of ``python -m mcd.run`` (registered in ``conf/config.yaml``, ``hydra.callbacks``), and
the place that registers ``${run_id:}`` for every command composing that config (see below).

:class:`SweepDirs`: before a sweep's first job, ``hydra.sweep.dir`` must be writable and no two jobs may
share a directory (:mod:`mcd.lit.sweep_dirs`); otherwise one ``error:`` line, exit status 2, nothing written.

:class:`FailedJobs`: a sweep runs every job (a failing job writes ``error.json`` and the sweep goes on,
``mcd.run``), then exits with status 1 naming how many jobs failed, so that scripts and CI see the failure.
"""

from __future__ import annotations

import contextlib
import logging
import sys
from pathlib import Path
from typing import Any

from hydra.experimental.callback import Callback
from omegaconf import DictConfig

from mcd.lit import run_dir

log = logging.getLogger("mcd.run")
# Hydra instantiates this module's callbacks before it resolves hydra.run.dir or hydra.sweep.dir, so every
# command composing conf/config.yaml gets the ${run_id:} of their defaults (mcd/lit/run_dir.py) from here
run_dir.register_resolvers()


class SweepDirs(Callback):
    """Refuse a sweep whose folder cannot be written or whose jobs share a directory, before it starts."""

    def on_multirun_start(self, config: DictConfig, **kwargs: Any) -> None:
        """:func:`mcd.lit.sweep_dirs.check_sweep`; its ValueError ends the command (``error:``, exit 2)."""
        from hydra.core.global_hydra import GlobalHydra

        from mcd.lit.sweep_dirs import check_sweep

        try:
            check_sweep(config, GlobalHydra.instance().config_loader())
        except ValueError as err:
            print(f"error: {err}", file=sys.stderr)
            sys.exit(2)


class FailedJobs(Callback):
    """Exit non-zero after a multirun in which a job wrote ``error.json``.

    This sweep's failures are the ``error.json`` files under ``hydra.sweep.dir`` that are new or rewritten
    since the sweep started: each is written atomically (:func:`mcd.run.write_error`), so a rewrite is a new
    file (another inode). An earlier sweep's failure in the same folder, even one written the moment before,
    is not this sweep's (a clock comparison would count it where the file system's timestamps are coarse or
    the two commands follow each other within their slack)."""

    def __init__(self) -> None:
        self.before: dict[Path, tuple[int, int, int]] = {}

    @staticmethod
    def _errors(sweep: Path) -> dict[Path, tuple[int, int, int]]:
        """Each ``error.json`` under ``sweep`` and its identity (inode, mtime in ns, size)."""
        found = {}
        for p in sweep.rglob("error.json"):
            with contextlib.suppress(FileNotFoundError):  # removed meanwhile (a retried job that passed)
                st = p.stat()
                found[p] = (st.st_ino, st.st_mtime_ns, st.st_size)
        return found

    def on_multirun_start(self, config: DictConfig, **kwargs: Any) -> None:
        """Remember the ``error.json`` files already there: they belong to earlier sweeps."""
        self.before = self._errors(Path(config.hydra.sweep.dir))

    def on_multirun_end(self, config: DictConfig, **kwargs: Any) -> None:
        """Count this sweep's ``error.json`` files (class docstring); exit 1 naming them if there are any."""
        sweep = Path(config.hydra.sweep.dir)
        failed = sorted(p.parent for p, ident in self._errors(sweep).items() if self.before.get(p) != ident)
        if failed:
            log.error("%d job(s) of the sweep in %s failed (each has an error.json): %s; fix them and rerun "
                      "the same command (finished jobs are skipped)", len(failed), sweep,
                      ", ".join(str(p.relative_to(sweep)) for p in failed))
            sys.exit(1)

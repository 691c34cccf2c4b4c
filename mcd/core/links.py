"""Symbolic links where a command writes (docs/reliability.md, "Campaign fixes"): a run wrote through such a
link into the file it points at, so the folders a run writes are checked for links before anything is written
(``mcd.config.compose`` for ``hydra.run.dir``, ``mcd.run`` for the job's output directory)."""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path


def linked_entries(run_dir: Path, names: Iterable[str]) -> list[Path]:
    """The symbolic links among ``names`` in ``run_dir`` and anywhere inside those of them that are folders
    (not followed): a run writes there, and wrote through such a link into the file it points at (a
    ``run.lock`` linked to a user's file had that file replaced by the run's pid line)."""
    found = []
    for name in names:
        path = run_dir / name
        if path.is_symlink():
            found.append(path)
        elif path.is_dir():
            for folder, dirs, files in os.walk(path):  # links to folders are listed in dirs, not followed
                found += [Path(folder) / e for e in (*dirs, *files) if (Path(folder) / e).is_symlink()]
    return sorted(found)


def check_links(key: str, run_dir: Path, names: Iterable[str]) -> None:
    """ValueError naming ``key`` (the setting that chose ``run_dir``) and the links of
    :func:`linked_entries`, before anything is written there."""
    links = linked_entries(run_dir, names)
    if links:
        shown = ", ".join(f"{p} -> {os.readlink(p)}" for p in links[:5])
        raise ValueError(f"{key}={run_dir} holds symbolic links where a run writes ({shown}"
                         f"{f', and {len(links) - 5} more' if len(links) > 5 else ''}): the run would write "
                         "through them into the files they point at; remove the links, or give the run a "
                         "new or empty folder")

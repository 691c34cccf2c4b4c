"""One atomic write of a file, for every writer whose file must be whole or absent under its final name: the
EXR store's frames and manifests (:mod:`mcd.data.exr`, :mod:`mcd.data.store_builder`), the training store's
arrays, records and ``store.json`` (:mod:`mcd.data.pack`), a run's ``metrics.json`` and ``job.json``
(:mod:`mcd.lit.run_record`), its trimmed ``metrics.csv`` (:mod:`mcd.lit.csv_log`) and ``mcd-denoise``'s
outputs (:mod:`mcd.denoise.output`); docs/reliability.md.

The guarantee: the content is written to a hidden temporary file in the final name's folder
(``.<name>.<random>.tmp<suffix>``, created exclusively, so concurrent writers never share one), then renamed
over the final name (``os.replace``). So

- the final name holds the old file or the whole new one, never part of one, whenever the writing process is
  killed (``kill -9`` included) or its writer raises; of concurrent writers, the last rename wins whole;
- the temporary file is removed when the writer raises (``KeyboardInterrupt`` included); those a killed
  process left are :func:`leftovers`, for a writer that holds its path's lock to remove (the EXR store removes
  every ``.*.tmp*`` of a scene or frame folder under its lock, :mod:`mcd.data.store_builder`);
- a symlink at the final name is replaced by the file, never written through (its target is untouched);
- the file gets the mode the umask gives a new file (``0o644`` under umask 022), as ``open`` would, not the
  ``0o600`` of :func:`tempfile.mkstemp`: a store shared with colleagues stays readable to them.

The file is not ``fsync``'d: the rename is atomic for other processes and survives the writer's death, not a
power loss (the kernel's page cache may not have reached the disk).
"""

from __future__ import annotations

import glob
import json
import os
import secrets
from collections.abc import Callable
from pathlib import Path
from typing import Any


def atomic_write(path: Path, write: Callable[[Path], None]) -> None:
    """Call ``write(tmp)`` on an empty temporary file beside ``path`` (same suffix, so writers that go by it
    pick the right format), then rename it to ``path`` (module docstring). ``write`` must have closed what it
    opened when it returns. The parent folder is made if missing."""
    path.parent.mkdir(parents=True, exist_ok=True)
    while True:
        tmp = path.with_name(f".{path.name}.{secrets.token_hex(4)}.tmp{path.suffix}")
        try:  # 0o666 less the umask, as a plain open gives
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        except FileExistsError:
            continue
        break
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def leftovers(path: Path) -> list[Path]:
    """The temporary files of :func:`atomic_write` calls on ``path`` that never finished (their process was
    killed, or is still writing: remove them only where no other writer of ``path`` can be live)."""
    return sorted(path.parent.glob(f".{glob.escape(path.name)}.*.tmp{glob.escape(path.suffix)}"))


def atomic_write_json(path: Path, obj: Any, *, indent: int = 1, default: Callable[[Any], Any] | None = None,
                      ) -> None:
    """``obj`` as indented JSON (``json.dumps(obj, indent=indent, default=default)`` and a newline) at
    ``path``, atomically (:func:`atomic_write`)."""
    text = json.dumps(obj, indent=indent, default=default) + "\n"
    atomic_write(path, lambda tmp: tmp.write_text(text))

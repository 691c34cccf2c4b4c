"""The run records a report keeps beside its tables (docs/benchmark.md "Reports", "Run records").

Run directories live under ``multirun/``, which git ignores: they hold checkpoints and sample EXRs, too large
to commit, and they do not outlive the machine that trained them. A report therefore copies each run's
*records* (:data:`RECORD_FILES`: the text files every table, finding and provenance line is computed from)
and each sweep's ``multirun.yaml`` into ``reports/<name>/runs/``, under the run's last three path parts
(``<sweep>/<data profile><tag>/<job>``). ``python -m mcd.report reports/<name>/runs --name <name>`` then
regenerates every table, finding and curve from the repository alone; only the strips, which need
``samples/``, and the edge effect, which needs the checkpoint, are not re-measured (``edges.json`` is kept
as measured).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from mcd.reporting.outputs import writes
from mcd.reporting.runs import RECORD_FILES, Run, Sweep

#: The folder of a report that holds its runs' records (every report kind's: mcd.reporting.outputs).
RECORDS_DIR, = writes("both", "runs")


def _key(path: Path) -> Path:
    """Where a run directory (or a sweep's ``multirun.yaml``) goes under ``runs/``: its last 3 path parts,
    never the root (``/`` of a run at ``/tmp/run``, which made the key absolute: the copy went onto the run's
    own files and ended the report in a SameFileError after its tables)."""
    parts = path.parts[1:] if path.is_absolute() else path.parts
    return Path(*parts[-3:])


def from_own_records(runs: list[Run], out_dir: Path) -> bool:
    """Whether every run of the report is read from the report's own ``runs/`` (a report regenerated from its
    records, which keep no samples): only then are an earlier viewer and strips of ``out_dir`` its runs' own,
    kept as measured; otherwise they show other runs and go (:func:`mcd.reporting.viewer.write`,
    ``mcd.report.remove_stale``)."""
    own = (out_dir / RECORDS_DIR).resolve()
    return all(own in r.path.resolve().parents for r in runs)


def keys(runs: list[Run]) -> list[Path]:
    """Each run's folder under ``runs/``; ValueError, naming them, when two runs from different places would
    share one (:func:`mcd.report.make_report` asks before it writes anything)."""
    found = [_key(r.path) for r in runs]
    clashes = sorted({str(k) for k in found if found.count(k) > 1})
    if clashes:
        raise ValueError(
            f"runs from different places would share the record folder(s) {', '.join(clashes)} under "
            f"{RECORDS_DIR}/: report them separately (--name), or rename one sweep's directory"
        )
    return found


def sweep_keys(sweeps: list[Sweep]) -> list[Path]:
    """Each sweep's folder under ``runs/`` (where its ``multirun.yaml`` goes); ValueError, naming them, when
    two sweeps from different places would share one: the second ``multirun.yaml`` replaced the first without
    a word, and the report regenerated from ``runs/`` gave the one sweep command left for the runs of both."""
    found = [_key(s.path / "multirun.yaml").parent for s in sweeps]
    places: dict[Path, set[Path]] = {}
    for key, sweep in zip(found, sweeps, strict=True):
        places.setdefault(key, set()).add(sweep.path.resolve())
    clashes = sorted(str(k) for k, where in places.items() if len(where) > 1)
    if clashes:
        raise ValueError(
            f"sweeps from different places would share the record folder(s) {', '.join(clashes)} under "
            f"{RECORDS_DIR}/ (one multirun.yaml would replace the other): report them separately (--name), "
            "or rename one sweep's directory"
        )
    return found


def keep(runs: list[Run], sweeps: list[Sweep], out_dir: Path) -> Path:
    """Copy the records of `runs` and the ``multirun.yaml`` of `sweeps` into ``out_dir/runs/``, replacing what
    an earlier report left there; returns that folder. The copies are made in a folder beside it first, so a
    report generated from its own ``runs/`` (or from it and new sweeps) reads every record before any is
    replaced."""
    dest = out_dir.resolve() / RECORDS_DIR
    staging = dest.with_name(RECORDS_DIR + ".new")
    shutil.rmtree(staging, ignore_errors=True)
    for run, key in zip(runs, keys(runs), strict=True):
        for name in RECORD_FILES:
            src = run.path / name
            if src.is_file():
                target = staging / key / name
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(src, target)
    for sweep, key in zip(sweeps, sweep_keys(sweeps), strict=True):
        src = sweep.path / "multirun.yaml"
        if src.is_file():
            target = staging / key
            target.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, target / "multirun.yaml")
    shutil.rmtree(dest, ignore_errors=True)
    staging.mkdir(parents=True, exist_ok=True)  # no run had a record file: an empty folder still replaces
    staging.rename(dest)
    return dest

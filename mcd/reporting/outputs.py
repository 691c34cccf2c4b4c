"""What each kind of report writes at the top of its folder, declared by the writers themselves
(docs/benchmark.md "Reports"; docs/architecture.md, "Sweeps, reports, speed").

A writer declares the names it writes (files or folders directly under the report folder) once, at module
level beside its code, with :func:`writes`, and builds its paths from the names it declared:
``FILES = writes("standard", "spp.csv", "spp.png")``. ``mcd.report.remove_stale`` removes, after a report is
written, the other kind's names and this kind's that it did not write this time, so a report folder rewritten
under one ``--name`` holds only what its own runs give: a new output file is removed when stale as soon as
its writer declares it, and ``tests/reliability/test_report_stale_files.py`` fails on a file that a real
report writes and no writer declares.
"""

from __future__ import annotations

import importlib
import pkgutil

#: The report kinds: ``standard`` (Table 1 and the rest), ``scaling`` (the scaling study's report) and
#: ``both`` (what every report writes: its README, findings, run records and viewer).
KINDS = ("standard", "scaling", "both")
_DECLARED: dict[str, list[str]] = {kind: [] for kind in KINDS}


def writes(kind: str, *names: str) -> tuple[str, ...]:
    """Declare that the calling writer writes ``names`` (top-level entries of the report folder) in reports of
    ``kind`` (:data:`KINDS`); returns ``names``. ValueError for an unknown kind or a name with a ``/``."""
    if kind not in _DECLARED:
        raise ValueError(f"report kind {kind!r}: one of {', '.join(KINDS)}")
    for name in names:
        if "/" in name or not name:
            raise ValueError(f"{name!r}: declare the top-level file or folder of the report, not a path")
        if name not in _DECLARED[kind]:
            _DECLARED[kind].append(name)
    return names


def declared(kind: str) -> tuple[str, ...]:
    """Every name the writers of reports of ``kind`` declare. Every module of :mod:`mcd.reporting` is imported
    first, so that each writer's declaration is in whichever of them a process has imported so far."""
    import mcd.reporting as package

    for module in pkgutil.walk_packages(package.__path__, f"{package.__name__}."):
        importlib.import_module(module.name)
    if kind not in _DECLARED:
        raise ValueError(f"report kind {kind!r}: one of {', '.join(KINDS)}")
    return tuple(_DECLARED[kind])

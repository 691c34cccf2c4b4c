"""``python -m mcd.report <multirun dir(s)> [--name N] [--bench reports/bench/bench.csv]``: the report
of one or more sweeps (docs/benchmark.md "Reports"), generated from the run directories only, under
``reports/<name>/``, then the reports index ``reports/README.md`` and, when the report is the current one
(``mcd.reporting.index.CURRENT_REPORT``), README.md's results block; ``python -m mcd.report --index``
writes those two alone (mcd/reporting/index.py). The report holds:

- ``table1.md/.csv`` (methods at 4 spp) and ``components.md/.csv`` (A-M), the paper's numbers beside ours,
  ``transfer.md/.csv`` when transfer jobs ran, ``seeds.md/.csv`` and ``seeds_differences.csv`` when the
  seeds sweep ran (run-to-run spread, the paper's claims with standard errors);
- ``spp.csv/.png`` (error against budget), ``speed_vs_error.png/.csv`` (each run's own model timed at its
  test frames' resolution, beside its error; ``mcd.reporting.speed``), ``speed_bench.csv`` (the bench CSV's
  latencies, under the bench's own capacity and resolution),
  ``curves.png/.csv`` (validation PSNR against training seconds and steps, one line per method);
- ``strips/<scene>.png`` and ``strips/<scene>_methods.png`` (qualitative, with crops),
  ``per_frame/<scene>_psnr.png`` (per-frame PSNR over each test sequence);
- ``viewer/index.html``: the comparison viewer (``mcd.reporting.viewer``), every method beside the noisy input
  and the reference per test frame, with wipe, synced zoom, exposure, FLIP maps and F's maps; opens from disk;
- ``findings.json`` (each finding as a record, ``mcd.reporting.finding``) and ``README.md``: provenance
  (commands, config, data profile, commit, device, wall time), the findings' prose (the paper's claims
  checked against our numbers, F against the trained baselines, OIDN and its noisy input), failed jobs with
  their error, and an index of the files.

Runs of the scaling sweep (``+sweep=scaling``; any runs with ``--kind scaling``) get the scaling study's
report instead, ``reports/scaling/`` (``mcd.reporting.scaling``; docs/benchmark.md "Scaling report").

A job whose ``metrics.json`` is corrupt (``mcd.reporting.runs.metrics_problem``) is reported as failed, and
the command then exits 1 naming each such file on stderr (docs/reliability.md).
"""

from __future__ import annotations

import argparse
import datetime as dt
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mcd.core.file_lock import exclusive_folder, folder_held_elsewhere
from mcd.core.paths import UnsafeNameError, check_folder_name
from mcd.core.provenance import commit_word
from mcd.reporting.outputs import writes

if TYPE_CHECKING:  # imported where used, so that --help starts fast (docs/architecture.md, "Start-up")
    import pandas as pd

    from mcd.reporting.finding import Finding
    from mcd.reporting.provenance import Provenance
    from mcd.reporting.runs import Run, Sweep

DEFAULT_BENCH = Path("reports/bench/bench.csv")
#: Every report's README (both kinds: the standard one here, the scaling one in mcd.reporting.scaling.report).
README, = writes("both", "README.md")


def _failures(runs: list[Run], root: Path) -> pd.DataFrame:
    import pandas as pd

    rows = []
    for r in runs:
        if r.status == "ok":
            continue
        try:
            where = str(r.path.relative_to(root))
        except ValueError:
            where = str(r.path)
        rows.append(
            {
                "run": where,
                "status": r.status,
                "overrides": " ".join(r.overrides),
                "error": r.error_message,
            }
        )
    return pd.DataFrame(rows, columns=["run", "status", "overrides", "error"])


def _regenerate_command(out_dir: Path, name: str, root: Path) -> str:
    """The command that regenerates the report at `out_dir` from its run records (mcd.reporting.records)."""
    from mcd.reporting import records

    where = out_dir.resolve()
    where = where.relative_to(root) if where.is_relative_to(root) else where
    out = "" if where.parent == Path("reports") else f" --out {where.parent}"
    return f"python -m mcd.report {where / records.RECORDS_DIR} --name {name}{out}"


def write_readme(
    out_dir: Path,
    name: str,
    prov: Provenance,
    runs: list[Run],
    sweeps: list[Sweep],
    results: dict[str, pd.DataFrame],
    files: list[Path],
    root: Path,
    notes: list[str],
    report_s: float,
    found: list[Finding],
    viewer: Path | None = None,
) -> Path:
    """The report's README: provenance, findings (the prose of ``found``), failures, index. Text from the
    runs' records passes :func:`mcd.reporting.markdown_text.escape`."""
    from mcd.reporting import finding
    from mcd.reporting.markdown_text import escape as esc
    from mcd.reporting.select import to_markdown

    fails = _failures(runs, root)
    lines = [
        f"# Report `{name}`",
        "",
        f"Generated {dt.datetime.now().astimezone().isoformat(timespec='seconds')} "
        f"by `{prov.report_command}` "
        f"at commit `{prov.report_commit}`, from run directories only (no hand edits).",
        "",
        *(
            [f"Compare the methods frame by frame in the [viewer]({viewer.relative_to(out_dir).as_posix()}) "
             "(opens from disk: wipe, synced zoom, exposure, FLIP error maps, F's maps).", ""]
            if viewer is not None
            else []
        ),
        *prov.readme_lines(root, _regenerate_command(out_dir, name, root), notes, report_s),
        "",
        f"## Findings (generated from the tables below; as data in [{finding.FILE}]({finding.FILE}))",
        "",
        *[f"- {esc(finding.render(f))}" for f in found],
        *([f"- {esc(mixed)}"] if (mixed := mixed_profiles_note(runs)) is not None else []),
        *([f"- {esc(code)}"] if found and (code := mixed_commits_note(runs)) is not None else []),
        "",
        "## Table 1 (4 spp)",
        "",
        to_markdown(results["table1"].drop(columns=["run"])),
        "## Component study",
        "",
        to_markdown(results["components"].drop(columns=["run"])),
    ]
    if "transfer" in results:
        lines += ["## Transfer", "", to_markdown(results["transfer"].drop(columns=["run"]))]
    if "seeds" in results:
        lines += ["## Run-to-run spread (seeds sweep)", "", to_markdown(results["seeds"])]
        if not results["seeds_differences"].empty:
            lines += [to_markdown(results["seeds_differences"])]
    lines += ["## Failed and incomplete jobs", ""]
    lines += [to_markdown(fails) if not fails.empty else "None."]
    lines += ["", "## Files", ""]
    lines += [f"- [{p.relative_to(out_dir)}]({p.relative_to(out_dir)})" for p in files]
    path = out_dir / README
    path.write_text("\n".join(lines) + "\n")
    return path


#: Data settings that leave a run's test scores as they are: the transfer scenes are scored in their own table
#: (``transfer.md``), so runs of one profile that differ only there still compare.
SCORE_FREE_SETTINGS = ("transfer_scenes",)


def _differ(a: dict[str, Any], b: dict[str, Any], key: str) -> bool:
    """Whether two runs' ``data_settings`` differ at ``key``; a scene's settings (``scenes.<name>.*``, which
    records from before them lack) are compared only where both record them."""
    if key.startswith("scenes.") and (key not in a or key not in b):
        return False
    return a.get(key) != b.get(key)


def profiles_of(runs: list[Run]) -> dict[str, int]:
    """``{data profile: number of runs}`` of the report's runs. A profile's name is followed by its capacity
    profile where the runs have more than one (``tiny`` capacity ``paper``), and by the data settings that
    differ (``width=48``, ``metrics.json`` ``data_settings``, a scene's camera path or file digest) where
    runs of one name were made from other data: their scores do not compare either
    (:data:`SCORE_FREE_SETTINGS` aside). A run without recorded settings (one that failed before its record)
    joins its profile's first group."""
    capacities = {r.capacity_profile for r in runs}
    differ: dict[str, list[str]] = {}  # per profile name, the data settings its runs differ in
    for name in {r.data_profile for r in runs}:
        kept = [r.data_settings for r in runs if r.data_profile == name and r.data_settings]
        differ[name] = sorted({k for a in kept for b in kept for k in {*a, *b}
                               if k not in SCORE_FREE_SETTINGS and _differ(a, b, k)})
    first = {name: next((r.data_settings for r in runs if r.data_profile == name and r.data_settings), None)
             for name in differ}
    counts: dict[str, int] = {}
    for r in runs:
        label = f"`{r.data_profile}`"
        if len(capacities) > 1:
            label += f" capacity `{r.capacity_profile}`"
        settings = r.data_settings or first[r.data_profile]
        if settings and differ[r.data_profile]:
            label += " (" + ", ".join(f"{k}={settings.get(k)}" for k in differ[r.data_profile]) + ")"
        counts[label] = counts.get(label, 0) + 1
    return dict(sorted(counts.items()))


def mixed_profiles_note(runs: list[Run]) -> str | None:
    """None when every run has one data profile (and one capacity profile, and the same data settings);
    else the sentence the README states where its findings would be: which profiles (and how many runs of
    each), and that no finding compares across them."""
    counts = profiles_of(runs)
    if len(counts) < 2:
        return None
    what = ("data profiles" if len({r.data_profile for r in runs}) == len(counts)
            else "data profiles, capacity profiles or data settings")
    listed = ", ".join(f"{p} ({n} run{'s' if n > 1 else ''})" for p, n in counts.items())
    return (f"None: the runs come from {len(counts)} {what}, {listed}, whose scores do not compare "
            "(other scenes, sizes, sample counts or models), so no finding is made across them and the "
            "tables below mix them. Report each profile's sweeps on their own.")


def mixed_commits_note(runs: list[Run]) -> str | None:
    """None when every finished run was made by one commit (a clean tree); else the sentence the README
    states under its findings: which commits (``+dirty``: uncommitted changes) made which runs, so that a
    finding between runs of two commits is not read as the methods' difference alone (the provenance listed
    the commits, but the findings compared such runs without a word)."""
    made: dict[str, list[str]] = {}
    for r in runs:
        if r.metrics is not None:
            code = commit_word(r.metrics.get("commit") or "unrecorded", r.metrics.get("dirty"))
            made.setdefault(code, []).append(r.path.name)
    if len(made) < 2:
        return None
    listed = "; ".join(f"{code}: {', '.join(sorted(names))}" for code, names in made.items())
    return (f"The runs come from {len(made)} versions of the code ({listed}): a finding between runs of two "
            "of them may hold the code's difference as well as the methods'.")


def gather_findings(runs: list[Run], results: dict[str, pd.DataFrame]) -> list[Finding]:
    """Every finding of the report, in the README's order (docs/benchmark.md "Reports", findings); none when
    the runs come from more than one data profile (:func:`mixed_profiles_note`)."""
    import pandas as pd

    from mcd.reporting import findings, map_health, seeds, tables

    if mixed_profiles_note(runs) is not None:
        return []
    return [
        *findings.headline(results["table1"]),
        *findings.baselines(results["table1"], results.get("seeds")),
        *findings.oidn_gap(runs, spread=results.get("seeds")),
        *findings.above_input(results["spp"]),
        *findings.against_budgets(results["spp"]),
        *tables.component_checks(results["components"]),
        *seeds.checks(results.get("seeds_differences", pd.DataFrame())),
        *seeds.reproducibility(runs),
        *map_health.checks(runs),
    ]


def report_name(runs: list[Run], name: str | None, scaling: bool = False) -> str:
    """The report's folder name under the output root: ``name`` (``--name``), else ``scaling`` for a scaling
    report, else the runs' one data profile (``combined`` for several). Either must be one plain folder name
    (:func:`mcd.core.paths.check_folder_name`): a profile comes from the runs' records (``data_profile`` in
    ``metrics.json``, or Hydra's choice of ``data`` in ``.hydra/hydra.yaml``), and ``/`` or ``..`` in it would
    write, and delete, outside the output root. UnsafeNameError naming the field and the file, or ``--name``,
    before anything is written."""
    why = "the report is written to <out>/<name>/"
    if name is not None:
        return _not_the_index(check_folder_name(name, "--name", why), "--name")
    if scaling:
        return "scaling"
    profiles = sorted({r.data_profile for r in runs})
    if len(profiles) > 1:
        return "combined"
    run = runs[0]
    source = (run.path / "metrics.json" if run.metrics is not None and "data_profile" in run.metrics
              else run.path / ".hydra" / "hydra.yaml")
    field = f"data_profile in {source}"
    return _not_the_index(check_folder_name(profiles[0], field, f"{why} and the default name is the runs' "
                                            "data profile (or give --name)"), field)


def _not_the_index(name: str, field: str) -> str:
    """``name``, or UnsafeNameError where it is the reports index's file name (any case): a report named
    ``README.md`` was written as the folder ``<out>/README.md``, and the index of that root then ended in an
    IsADirectoryError traceback, after this report and every later one."""
    from mcd.reporting.index import INDEX

    if name.lower() == INDEX.lower():
        raise UnsafeNameError(f"{field}={name!r}: the name of the reports index (<out>/{INDEX}); give "
                              "another --name")
    return name


#: The first line of the ``notes.md`` that a scaling report writes (:mod:`mcd.reporting.scaling.notes`); a
#: ``notes.md`` that does not start with it is the user's own, which a report never writes or removes.
GENERATED_NOTES = "# Scaling study: generated notes"


def remove_stale(out_dir: Path, written: list[Path], scaling: bool, regenerated: bool = False) -> list[str]:
    """Remove from ``out_dir`` what an earlier report wrote there and this one did not: the names the other
    kind's writers declare and this kind's that are absent from ``written`` (:mod:`mcd.reporting.outputs`;
    an earlier standard report's ``table1.csv`` left beside a scaling report became README.md's results of the
    current report). A standard report ``regenerated`` from its own run records keeps ``strips/`` (kept as
    measured: the records hold no samples, like the viewer; :func:`mcd.reporting.records.from_own_records`),
    and a ``notes.md`` goes only where a report generated it (:data:`GENERATED_NOTES`). Returns the names
    removed. Nothing else of the folder is touched."""
    import shutil

    from mcd.reporting import outputs, strips
    from mcd.reporting.scaling import notes

    kept = {p.relative_to(out_dir).parts[0] for p in written}
    ours, theirs = ("scaling", "standard") if scaling else ("standard", "scaling")
    stale = [*outputs.declared(theirs),
             *(n for n in outputs.declared(ours)
               if n not in kept and not (n == strips.DIR and not scaling and regenerated))]
    removed = []
    for name in stale:
        path = out_dir / name
        if name == notes.FILE and not _written_by_report(path, GENERATED_NOTES):
            continue  # the user's own notes (or none)
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        elif path.exists() or path.is_symlink():
            path.unlink()
        else:
            continue
        removed.append(name)
    return removed


class ReportOutError(ValueError):
    """``--out`` would overwrite a file that ``mcd.report`` did not write, or put the report inside a run or
    sweep directory it reads (``mcd.report``: one line, nothing written)."""


def _written_by_report(path: Path, first_line: str) -> bool:
    """Whether ``path`` is a file whose first line starts with ``first_line`` (what mcd.report writes)."""
    if not path.is_file():
        return False
    with open(path, encoding="utf-8", errors="replace") as f:
        return f.readline().startswith(first_line)


def _linked(path: Path) -> bool:
    """Whether ``path`` is a symlink, or a file whose bytes other names share (a hard link): a report writing
    there (most of its files are written in place, not renamed) changed a user's file outside its folder."""
    return path.is_symlink() or (path.is_file() and path.stat().st_nlink > 1)


def check_out(out_root: Path, out_dir: Path | None = None, reads: list[Path] | None = None,
              scaling: bool = False) -> None:
    """ReportOutError, before anything is written, where ``<out>/README.md`` exists and is not a reports index
    (:func:`mcd.reporting.index.write_index` replaced a user's own README.md with the index), where
    ``out_dir/README.md`` exists and is not a report's, or where ``out_dir`` is one of the folders of runs
    ``reads`` (run, sweep and given directories), lies inside one, or holds one other than below its own
    ``runs/`` (the report's files joined a finished run's, and its ``runs/`` copies then made every later
    report of the sweep refuse their clash). A report regenerated from its own ``runs/`` passes. A scaling
    report (``scaling``) is refused where ``out_dir/notes.md`` is the user's own (:data:`GENERATED_NOTES`):
    it writes its generated notes there."""
    from mcd.reporting import records
    from mcd.reporting.index import INDEX

    for folder, what in ((out_root, "--out"), (out_dir, "the report folder")):
        if folder is not None and folder.exists() and not folder.is_dir():
            raise ReportOutError(f"{what} {folder} is a file, not a folder; give another --out (or --name)")
    for path, first, what in ((out_root / INDEX, "# Reports", f"the reports index of --out {out_root}"),
                              *(((out_dir / "README.md", "# Report `", f"the report's README in {out_dir}"),)
                                if out_dir is not None else ())):
        if path.exists() and not _written_by_report(path, first):
            raise ReportOutError(f"{path}: not written by mcd.report (its first line is not {first!r}), and "
                                 f"{what} would replace it; give another --out (or --name)")
    if out_dir is None:
        return
    from mcd.reporting import outputs, viewer

    declared = sorted({n for kind in outputs.KINDS for n in outputs.declared(kind)})  # what any report writes
    # and the records and viewer being written before they replace the old ones
    staging = (f"{records.RECORDS_DIR}.new", f".{viewer.VIEWER_DIR}.partial")
    for path in (out_root / INDEX, *(out_dir / name for name in (*declared, *staging))):
        inside = sorted(p for p in path.rglob("*") if _linked(p)) if path.is_dir() else []
        links = [path] if _linked(path) else inside
        if links:  # written or removed through it, the report would change what lies outside its folder
            to = (f"to {os.readlink(links[0])}" if links[0].is_symlink()
                  else f"a hard link: {links[0].stat().st_nlink} names share its bytes")
            raise ReportOutError(f"{links[0]}: a link where the report writes ({to}); a report writes only "
                                 "inside its folder: remove the link, or give another --name")
    if folder_held_elsewhere(out_dir):  # a report being written has no README yet: never "delete its folder"
        raise ReportOutError(f"{out_dir}: another mcd.report is writing this report now; wait for it to "
                             "finish, or give another --name")
    if out_dir.is_dir() and not (out_dir / "README.md").exists():  # no report wrote there: a user's folder
        found = [n for n in declared if (out_dir / n).exists() or (out_dir / n).is_symlink()]
        if found:
            raise ReportOutError(f"{out_dir}: holds {', '.join(found[:3])} and no report README.md, so no "
                                 "report wrote them, and a report would replace them; move them, or give "
                                 "another --name (a report stopped before its README: delete its folder)")
    notes = out_dir / "notes.md"
    if scaling and notes.exists() and not _written_by_report(notes, GENERATED_NOTES):
        raise ReportOutError(f"{notes}: hand-written notes (its first line is not {GENERATED_NOTES!r}), "
                             "and a scaling report writes its generated notes.md there; give another --name "
                             "(or move the notes)")
    where = out_dir.resolve()
    for read in reads or []:
        inside = where in read.parents and (where / records.RECORDS_DIR) not in (read, *read.parents)
        if where == read or read in where.parents or inside:
            raise ReportOutError(f"--out {out_root}: the report folder {out_dir} is, holds or lies inside "
                                 f"{read}, a folder of runs the report reads; give an --out outside them")


def make_report(
    dirs: list[Path],
    out_root: Path,
    name: str | None = None,
    bench: Path | None = DEFAULT_BENCH,
    notes: list[str] | None = None,
    command: str | None = None,
    with_viewer: bool = True,
    kind: str = "auto",
    current: str | None = None,
    readme: Path | None = None,
) -> Path:
    """Write the whole report for the runs under `dirs`; returns the report directory. ``with_viewer=False``
    writes no viewer and removes an earlier one (``mcd.reporting.viewer.remove``). ``kind``: ``scaling``
    writes the scaling study's report (``mcd.reporting.scaling``), ``standard`` the report above, ``auto``
    the scaling report where a run is a job of the scaling sweep (``mcd.reporting.scaling.grid.is_scaling``).
    ``current``: the current report's name, whose Table 1 README.md's results show; a scaling report, which
    has none, is refused under it before anything is written, and so is a report under it (``--name``, or
    the runs' data profile) where ``readme`` lacks the results markers (it ended in a traceback after the
    report was written).
    """
    from mcd.reporting import records
    from mcd.reporting.runs import NoRunsError, find_runs, find_sweeps
    from mcd.reporting.scaling.grid import is_scaling
    from mcd.reporting.strips import UNREADABLE

    started = time.perf_counter()
    UNREADABLE.clear()  # this report's damaged samples, not an earlier report's of the same process
    runs = find_runs(dirs)
    if not runs:
        raise NoRunsError(
            f"no run directories (metrics.json / error.json / .hydra) under "
            f"{', '.join(map(str, dirs))}: pass the multirun dirs of `mcd.run -m`"
        )
    from mcd.reporting.speed import bench_problem

    if (problem := bench_problem(bench)) is not None:
        raise ReportOutError(f"{problem}; give a CSV of python -m mcd.bench speed as --bench")
    sweeps = find_sweeps(dirs)
    try:  # two runs, or two sweeps, that would share a record folder: refused before anything is written
        records.keys(runs)
        records.sweep_keys(sweeps)
    except ValueError as err:
        raise ReportOutError(str(err)) from err
    scaling = kind == "scaling" or (kind == "auto" and is_scaling(runs))
    name = report_name(runs, name, scaling)
    out_dir = out_root / name
    if scaling and name == current:
        raise ReportOutError(f"--name {name} is the current report, whose Table 1 README.md's results show, "
                             "and a scaling report has no Table 1; give the scaling report another --name")
    if name == current and readme is not None:  # README.md's markers, before any long work
        from mcd.reporting import index

        try:
            index.markers(readme)
        except (FileNotFoundError, ValueError) as err:
            raise ReportOutError(f"the report {name} is the current one, whose results go into {readme}: "
                                 f"{err}") from err
    check_out(out_root, out_dir, [*(r.path for r in runs), *(s.path.resolve() for s in sweeps),
                                  *(d.resolve() for d in dirs)], scaling)
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as err:  # a read-only or full disk: named, nothing written (it was a traceback)
        raise ReportOutError(f"--out {out_root}: cannot make the report folder {out_dir} ({err.strerror}); "
                             "give a writable --out") from err
    with exclusive_folder(out_dir) as held:
        if not held:
            raise ReportOutError(f"{out_dir}: another mcd.report is writing this report now; wait for it to "
                                 "finish, or give another --name")
        _write(runs, sweeps, out_dir, name, bench, notes, command, with_viewer, scaling, started)
    return out_dir


def _write(runs: list[Run], sweeps: list[Sweep], out_dir: Path, name: str, bench: Path | None,
           notes: list[str] | None, command: str | None, with_viewer: bool, scaling: bool,
           started: float) -> None:
    """:func:`make_report`'s writing, with ``out_dir`` locked: every file, then :func:`remove_stale`."""
    from mcd.reporting import (
        curves,
        finding,
        frames,
        outputs,
        records,
        seeds,
        speed,
        spp,
        strips,
        tables,
        viewer,
    )
    from mcd.reporting.provenance import Provenance

    root = Path.cwd().resolve()
    prov = Provenance.gather(sweeps, runs, command)
    if scaling:
        from mcd.reporting.scaling import report as scaling_report

        scaling_report.write(runs, out_dir, name, prov, root,
                             _regenerate_command(out_dir, name, root) + " --kind scaling", notes or [],
                             started, with_viewer)
        records.keep(runs, sweeps, out_dir)
        remove_stale(out_dir, [out_dir / n for n in outputs.declared("scaling") if (out_dir / n).exists()],
                     scaling=True)
        return

    regenerated = records.from_own_records(runs, out_dir)  # before records.keep replaces runs/
    results = tables.write_all(runs, out_dir, root)
    results.update(seeds.write(runs, out_dir))
    results["spp"] = spp.write(runs, out_dir, prov, root)
    speed_files = speed.write(runs, bench, out_dir, prov)
    strip_files = strips.write(runs, out_dir, prov)
    frame_files = frames.write(runs, out_dir, prov)
    curve_files = curves.write(runs, out_dir, prov)
    viewer_page = viewer.write(runs, out_dir, name) if with_viewer else None
    if not with_viewer:
        viewer.remove(out_dir)
    records.keep(runs, sweeps, out_dir)

    found = gather_findings(runs, results)
    finding.write(found, out_dir)

    files = [out_dir / f for f in ("findings.json", "table1.md", "table1.csv", "components.md",
                                   "components.csv")]
    if "transfer" in results:
        files += [out_dir / "transfer.md", out_dir / "transfer.csv"]
    if "seeds" in results:
        files += [out_dir / "seeds.md", out_dir / "seeds.csv"]
        if not results["seeds_differences"].empty:
            files.append(out_dir / "seeds_differences.csv")
    files += [out_dir / spp.PNG, out_dir / spp.CSV, *speed_files]  # this report's, not an earlier one's
    files += curve_files + strip_files + frame_files
    if frame_files:
        files.append(out_dir / "per_frame" / "per_frame.csv")
    if viewer_page is not None:
        files.append(viewer_page)
    write_readme(
        out_dir, name, prov, runs, sweeps, results, files, root, notes or [], time.perf_counter() - started,
        found,
        viewer_page,
    )
    remove_stale(out_dir, files, scaling=False, regenerated=regenerated)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m mcd.report", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("dirs", nargs="*", type=Path, help="multirun dirs (e.g. multirun/ablation/tiny)")
    parser.add_argument("--name", help="report name: reports/<name>/ (default: the runs' data profile)")
    parser.add_argument("--out", type=Path, default=Path("reports"), help="reports root (default: reports)")
    parser.add_argument(
        "--bench",
        type=Path,
        default=DEFAULT_BENCH,
        help=f"bench CSV of python -m mcd.bench (default: {DEFAULT_BENCH})",
    )
    parser.add_argument(
        "--note",
        action="append",
        default=[],
        help="a line for the README's provenance (e.g. reduced epochs); repeatable",
    )
    parser.add_argument(
        "--no-viewer",
        action="store_true",
        help="write no comparison viewer (<report>/viewer/, the heaviest part) and remove an earlier one",
    )
    parser.add_argument(
        "--kind",
        choices=("auto", "standard", "scaling"),
        default="auto",
        help="scaling: the scaling study's report (docs/benchmark.md \"Scaling report\"); standard: Table 1 "
        "and the rest; auto (default): scaling where a run is a job of +sweep=scaling",
    )
    parser.add_argument(
        "--index",
        action="store_true",
        help="only write the reports index (<out>/README.md) and README.md's results from the current report",
    )
    parser.add_argument(
        "--readme",
        type=Path,
        help="the README.md whose results block shows the current report (default: <out>/../README.md)",
    )
    parser.add_argument(
        "--current",
        help="the current report's name (default: mcd.reporting.index.CURRENT_REPORT)",
    )
    args = parser.parse_args(argv)
    if not args.index and not args.dirs:
        parser.error("give the multirun dirs to report on, or --index")
    from mcd.reporting import index

    current = args.current or index.CURRENT_REPORT
    try:  # a folder of --out: "../../x" read a folder outside it into README.md's results
        check_folder_name(current, "--current", "the current report is the folder <out>/<name>/")
    except UnsafeNameError as err:
        sys.exit(f"error: {err}")
    readme = args.readme or args.out.resolve().parent / "README.md"
    if args.index:  # README.md's markers are checked before any work (a report's: in make_report)
        try:
            index.markers(readme)
        except (FileNotFoundError, ValueError) as err:
            sys.exit(f"error: {err}")
    if args.index:
        try:
            check_out(args.out)
        except ReportOutError as err:
            sys.exit(f"error: {err}")
        try:
            index.update_readme(readme, index.results_block(args.out / current, readme.parent))
        except FileNotFoundError as err:
            sys.exit(f"error: {err}")
        print(f"index written to {index.write_index(args.out, current)}; results of {current} in {readme}")
        return
    from mcd.reporting.runs import NoRunsError

    command = "python -m mcd.report " + " ".join(argv if argv is not None else sys.argv[1:])
    try:
        out_dir = make_report(args.dirs, args.out, args.name, args.bench, args.note, command,
                              not args.no_viewer, args.kind, current, readme)
    except (UnsafeNameError, NoRunsError, ReportOutError) as err:  # a name leaving the output root, an --out
        # over files it did not write, or nothing to report on:
        sys.exit(f"error: {err}")  # one line, and nothing was written
    print(f"report written to {out_dir}/README.md")
    print(f"index written to {index.write_index(args.out, current)}")
    if out_dir.name == current:
        index.update_readme(readme, index.results_block(out_dir, readme.parent))
        print(f"results of {current} written to {readme}")
    from mcd.reporting.runs import find_runs
    from mcd.reporting.strips import UNREADABLE

    corrupt = [r.corrupt for r in find_runs(args.dirs) if r.corrupt]
    for problem in corrupt:  # the report lists these jobs as failed; the exit status says the inputs were bad
        print(f"error: {problem}; the job is reported as failed: run it again", file=sys.stderr)
    for problem in UNREADABLE.values():
        print(f"error: {problem}; left out of the strips and the viewer", file=sys.stderr)
    if corrupt or UNREADABLE:
        sys.exit(1)


if __name__ == "__main__":
    main()

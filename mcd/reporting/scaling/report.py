"""The scaling report's files (docs/benchmark.md "Scaling report"), written by :func:`mcd.report.make_report`
for runs of the scaling sweep (or with ``--kind scaling``):

- ``scaling.png`` (:mod:`mcd.reporting.scaling.plot`);
- ``scaling_cells.md/.csv``: every cell (data, steps, method) of the plan and of the runs, its seeds, band
  rule, PSNR, FLIP and the training scenes' PSNR (mean, standard error, range), ``no runs`` where it has none;
- ``scaling_gaps.md/.csv``: F - NTASAD, F - U-Net and the other pairs per scale point
  (:mod:`mcd.reporting.scaling.gaps`), and ``scaling_gaps.png``, each with its error bar
  (:mod:`mcd.reporting.scaling.gaps_plot`);
- ``scaling_fits.md/.csv``: PSNR against log10(steps) per method and data profile, and where F meets NTASAD
  and the U-Net (:mod:`mcd.reporting.scaling.fit`);
- ``scaling_jobs.csv``: every job of the sweep's plan with its state, and the runs outside it
  (:mod:`mcd.reporting.scaling.coverage`);
- ``findings.json``, ``notes.md`` (:mod:`mcd.reporting.scaling.notes`), the viewer of the runs at the largest
  scale point the methods share (:meth:`Grid.viewer_point`, :mod:`mcd.reporting.viewer`) and ``README.md``
  (provenance, the answer, findings, tables, files).
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import pandas as pd

from mcd.config.methods import display_name
from mcd.reporting import finding, map_health, viewer
from mcd.reporting.finding import Finding
from mcd.reporting.markdown_text import escape as esc
from mcd.reporting.outputs import writes
from mcd.reporting.provenance import Provenance
from mcd.reporting.runs import Run
from mcd.reporting.scaling import coverage, fit, gaps, gaps_plot, notes, plot
from mcd.reporting.scaling.grid import Grid, cells, order, read, root_relative
from mcd.reporting.select import to_markdown

#: FLIP is shown x1e2 in the markdown tables (two decimals); the CSV files keep full precision.
FLIP_SCALE = 100.0

#: The tables it writes in the report's folder beside the figure and the notes (mcd.reporting.outputs):
#: ``<stem>.csv`` for each stem, ``<stem>.md`` for those with a section below.
CSV_STEMS = ("scaling_cells", "scaling_gaps", "scaling_fits", "scaling_crossings", "scaling_jobs")
MD_STEMS = ("scaling_cells", "scaling_gaps", "scaling_fits")
FILES = writes("scaling", *(f"{stem}.csv" for stem in CSV_STEMS), *(f"{stem}.md" for stem in MD_STEMS))


def scale_points(grid: Grid, plan: pd.DataFrame) -> list[tuple[str, int]]:
    """Every (data, steps) of the plan and of the runs: the plan's data profiles in its order (smallest
    first), then other profiles with runs by size; steps ascending."""
    data = list(dict.fromkeys([*plan["data"], *grid.data]))
    points = {(str(d), int(s)) for d, s in zip(plan["data"], plan["steps"], strict=True)}
    points |= {(str(d), int(s)) for d, s in zip(grid.points["data"], grid.points["steps"], strict=True)}
    return sorted(points, key=lambda p: (data.index(p[0]), p[1]))


def cell_table(table: pd.DataFrame, plan: pd.DataFrame, points: list[tuple[str, int]]) -> pd.DataFrame:
    """The cells of the runs (:func:`mcd.reporting.scaling.grid.cells`) and the plan's cells without runs
    (``n`` 0, ``band`` ``no runs``), by scale point, then method."""
    have = set() if table.empty else set(zip(table["data"], table["steps"], table["experiment"], strict=True))
    empty = [{"data": d, "steps": int(s), "experiment": e, "n": 0, "seeds": "none", "band": "no runs"}
             for d, s, e in plan[["data", "steps", "experiment"]].drop_duplicates().itertuples(index=False)
             if (d, int(s), e) not in have]
    out = pd.concat([table, pd.DataFrame(empty)], ignore_index=True) if empty else table.copy()
    if out.empty:
        return out
    rank = {p: i for i, p in enumerate(points)}
    exp_rank = {e: i for i, e in enumerate(order(set(out["experiment"])))}
    out["_order"] = [(rank[(d, int(s))], exp_rank[e]) for d, s, e in
                     zip(out["data"], out["steps"], out["experiment"], strict=True)]
    return out.sort_values("_order").drop(columns="_order").reset_index(drop=True)


def _cells_markdown(df: pd.DataFrame) -> str:
    cols = {"data": "data", "steps": "steps", "experiment": "experiment", "n": "n", "seeds": "seeds",
            "band": "band", "psnr mean": "PSNR", "psnr se": "PSNR se", "psnr min": "PSNR min",
            "psnr max": "PSNR max", "flip mean": "FLIP x1e2", "flip se": "FLIP se x1e2",
            "psnr_train mean": "PSNR train scenes", "stopped early": "stopped early", "code": "code"}
    shown = df[[c for c in cols if c in df.columns]].rename(columns=cols)
    for c in ("FLIP x1e2", "FLIP se x1e2"):
        if c in shown:
            shown[c] = shown[c] * FLIP_SCALE
    return to_markdown(shown.fillna({c: "" for c in ("stopped early", "code") if c in shown}))


def _gaps_markdown(df: pd.DataFrame) -> str:
    shown = df.drop(columns=["a", "b", "train scenes"]).rename(columns={"FLIP": "FLIP x1e2",
                                                                         "FLIP se": "FLIP se x1e2"})
    shown["FLIP x1e2"] *= FLIP_SCALE
    shown["FLIP se x1e2"] *= FLIP_SCALE
    return to_markdown(shown)


def _crossing_table(crossed: list[tuple[str, str, str, fit.Crossing]]) -> pd.DataFrame:
    return pd.DataFrame([{"data": d, "pair": f"{display_name(a)} - {display_name(b)}", "outcome": c.outcome,
                          "crossing steps": c.steps,
                          "largest budget": c.largest, "dB per decade (first - second)": c.per_decade,
                          "not above at": ",".join(map(str, c.behind))} for d, a, b, c in crossed],
                        columns=["data", "pair", "outcome", "crossing steps", "largest budget",
                                 "dB per decade (first - second)", "not above at"])


def write(runs: list[Run], out_dir: Path, name: str, prov: Provenance, root: Path, regenerate: str,
          notes_lines: list[str], started: float, with_viewer: bool = True) -> Path:
    """Write the scaling report of ``runs`` into ``out_dir`` (module docstring); returns its README.
    ``regenerate`` is the command that rebuilds it from its run records; ``started`` the
    ``time.perf_counter()`` at which the report began."""
    import time

    grid = read(runs)
    table = cells(grid)
    plan = coverage.planned()
    jobs = coverage.jobs(runs, grid, plan)
    points = scale_points(grid, plan)
    gap_table = gaps.table(grid, points)
    data = list(dict.fromkeys(d for d, _ in points))
    ran = grid.points
    expected = [(d, e) for d in data for e in order(
        {*plan.loc[plan["data"] == d, "experiment"], *ran.loc[ran["data"] == d, "experiment"]})]
    fit_table = fit.fits(table, expected)
    crossed = fit.crossings(table, data)
    used = [r for r in runs if str(r.path) in set(grid.points["path"])]
    found: list[Finding] = [coverage.finding(jobs), *gaps.findings(gap_table),
                            *fit.findings(fit_table, crossed), *map_health.checks(used)]
    finding.write(found, out_dir)

    shown_cells = cell_table(table, plan, points)
    cross_table = _crossing_table(crossed)
    csv_tables = {"scaling_cells": shown_cells, "scaling_gaps": gap_table, "scaling_fits": fit_table,
                  "scaling_crossings": cross_table,
                  "scaling_jobs": jobs.assign(run=[root_relative(p, root) if p else "" for p in jobs["run"]])}
    for stem in CSV_STEMS:
        csv_tables[stem].to_csv(out_dir / f"{stem}.csv", index=False)
    png = plot.write(grid, table, out_dir, prov)
    if png is None:
        (out_dir / plot.FILE).unlink(missing_ok=True)
    gaps_png = gaps_plot.write(gap_table, out_dir, prov)
    if gaps_png is None:
        (out_dir / gaps_plot.FILE).unlink(missing_ok=True)
    notes_path = notes.write(found, out_dir, regenerate)

    largest = grid.viewer_point()
    page = None
    if with_viewer and largest is not None:
        page = viewer.write(grid.runs_at(runs, *largest), out_dir, name)
    elif not with_viewer:
        viewer.remove(out_dir)

    sections = {
        "scaling_cells": ("Cells: each method at each scale point",
                          "`n`: seeds with a finished run (0: no runs yet); `band`: what the figure's band "
                          "shows (mean ± standard error from 3 seeds, the range with 2, none with 1); `se`: "
                          "sample standard deviation over sqrt(n); FLIP x1e2 (lower is better); `PSNR train "
                          "scenes`: over the training scenes' test frames only (the paper's protocol); "
                          "`code`: the commits that trained the cell's runs (each run's, `+` where it was "
                          "resumed under another).",
                          _cells_markdown(shown_cells) if not shown_cells.empty else "No cells.\n"),
        "scaling_gaps": ("Differences at each scale point",
                         "PSNR in dB, FLIP x1e2 (a negative FLIP difference favours the first method). "
                         "`rule`: paired by seed over the seeds both cells have where they share two or "
                         "more; that seed's difference where a side has one seed the other has too; else "
                         "the difference of the means, with the standard error sqrt(s_a^2/n_a + s_b^2/n_b) "
                         "where both have two or more seeds and none otherwise; `none`: the cell has no "
                         "runs. `code`: `same` where one commit trained every run of both cells, else each "
                         "side's commits: the same seed under other numerics takes another trajectory, so a "
                         "difference across code holds the code's difference too, which no standard error "
                         "here counts.",
                         (f"![{gaps_plot.FILE}]({gaps_plot.FILE})\n\n" if gaps_png is not None else "")
                         + _gaps_markdown(gap_table)),
        "scaling_fits": ("Fits of PSNR against log10(steps), per method and data profile",
                         "PSNR = a + b log10(steps) by least squares through the cell means (one point per "
                         "budget); `b`: dB per tenfold steps; `rms residual`: root mean square distance of "
                         "the points from the line (0 by construction with two budgets). Below, where F's "
                         f"fit meets {display_name('ntasad')}'s and the {display_name('unet')}'s "
                         "(docs/benchmark.md \"Scaling report\").",
                         to_markdown(fit_table) + "\n" + to_markdown(cross_table)),
    }
    for stem, (title, note, body) in sections.items():
        (out_dir / f"{stem}.md").write_text(f"# {title}\n\n{note}\n\n{body}")

    files = [out_dir / finding.FILE, notes_path, *(out_dir / f"{stem}.md" for stem in MD_STEMS),
             *(out_dir / f"{stem}.csv" for stem in CSV_STEMS)]
    if png is not None:
        files.insert(0, png)
    if page is not None:
        files.append(page)
    readme = out_dir / "README.md"
    where = f"{largest[0]} x {largest[1]} steps" if largest is not None else ""
    lines = [
        f"# Report `{name}`: the scaling study",
        "",
        f"Generated {dt.datetime.now().astimezone().isoformat(timespec='seconds')} by "
        f"`{prov.report_command}` at commit `{prov.report_commit}`, from run directories only (no hand "
        "edits).",
        "",
        esc(notes.answer(found)) + f" More in [{notes_path.name}]({notes_path.name}).",
        "",
        *([f"The [viewer]({page.relative_to(out_dir).as_posix()}) shows the runs of the largest scale point "
           f"the methods share, {esc(where)} (opens from disk: wipe, synced zoom, exposure, FLIP error maps, "
           "F's maps).", ""]
          if page is not None else []),
        *prov.readme_lines(root, regenerate, notes_lines, time.perf_counter() - started),
        "",
        f"## Findings (as data in [{finding.FILE}]({finding.FILE}))",
        "",
        *[f"- {esc(finding.render(f))}" for f in found],
        "",
        "## Error against optimiser steps",
        "",
        *([f"![{plot.FILE}]({plot.FILE})", ""] if png is not None else ["No finished run: no figure.", ""]),
    ]
    for stem, (title, note, body) in sections.items():
        lines += [f"## {title} ([{stem}.md]({stem}.md), [{stem}.csv]({stem}.csv))", "", note, "", body]
    not_done = jobs[~jobs["status"].isin(("finished", "outside the plan"))]
    lines += ["## Jobs of the plan not finished", "",
              f"{len(not_done)} of {int((jobs['status'] != 'outside the plan').sum())} planned jobs "
              f"([scaling_jobs.csv](scaling_jobs.csv) lists every job with its state)."
              + (" Failed and incomplete ones:" if not_done["status"].isin(("failed", "incomplete")).any()
                 else ""), ""]
    for r in runs:
        if r.status != "ok":
            lines.append(f"- `{esc(root_relative(str(r.path), root))}`: {r.status}: {esc(r.error_message)}")
    lines += ["", "## Finished runs left out", ""]
    lines += [f"- {esc(x)}" for x in grid.left_out] or ["None."]
    lines += ["", "## Files", ""]
    lines += [f"- [{p.relative_to(out_dir)}]({p.relative_to(out_dir)})" for p in files]
    readme.write_text("\n".join(lines) + "\n")
    return readme


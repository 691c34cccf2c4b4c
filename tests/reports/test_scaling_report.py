"""The scaling study's report (mcd/reporting/scaling/, docs/benchmark.md "Scaling report"): the fit and
crossing arithmetic and the difference rule on hand-checkable numbers, the generated answer's rule, and a real
grid end to end: ``python -m mcd.run -m +sweep=scaling`` on the session's 32x32 Cornell box (F, NTASAD and
row A at 2 and 4 real optimiser steps, a second seed at 4), then ``python -m mcd.report`` on its directory."""

from __future__ import annotations

import json
import math
import re
import subprocess
from pathlib import Path

import pandas as pd
import pytest

from mcd.config.methods import display_name
from mcd.reporting import finding, outputs
from mcd.reporting.finding import Finding
from mcd.reporting.scaling import coverage, notes
from mcd.reporting.scaling import gaps as scaling_gaps
from mcd.reporting.scaling.fit import HORIZON, crossing, fit_log_steps
from mcd.reporting.scaling.gaps import difference
from mcd.reporting.scaling.grid import Grid
from tests.conftest import command_in_worker, store32_overrides

REPO = Path(__file__).resolve().parents[2]


def test_the_fit_is_least_squares_on_log10_steps_with_its_rms_residual():
    exact = fit_log_steps({1000: 26.0, 3000: 26.0 + 2 * math.log10(3), 10000: 28.0})
    assert exact.a == pytest.approx(20.0) and exact.b == pytest.approx(2.0) and exact.rms == pytest.approx(0)
    # x = 1, 2, 3 and y = 1, 3, 2: slope 0.5, intercept 1, residuals -0.5, 1, -0.5
    f = fit_log_steps({10: 1.0, 100: 3.0, 1000: 2.0})
    assert (f.a, f.b, f.rms) == pytest.approx((1.0, 0.5, math.sqrt(0.5)))
    assert f.budgets == (10, 100, 1000) and f.at(10000) == pytest.approx(3.0)
    assert fit_log_steps({1000: 25.0}) is None and fit_log_steps({}) is None


def _line(a: float, b: float, budgets=(1000, 10000)) -> dict[int, float]:
    return {s: a + b * math.log10(s) for s in budgets}


@pytest.mark.parametrize("f, other, outcome, steps", [
    # ahead at every budget both ran: no fit needed
    (_line(21, 3), _line(20, 3), "ahead", math.nan),
    # F 29, 32 against 31.25, 32.75: F gains 1 dB per decade more, the fits meet at 10**4.25
    (_line(20, 3), _line(24.25, 2), "crosses", 10 ** 4.25),
    # the same gain, 10**7: 1000x the largest budget, beyond the horizon
    (_line(20, 3), _line(27, 2), "no crossing", 1e7),
    # F gains less per decade and is behind: the gap does not close
    (_line(20, 3), _line(20, 4), "no crossing", math.nan),
    # level at 1000 steps (not above), ahead at 10000: the fits met at 1000
    (_line(20, 3), _line(26, 1), "crossed", 1000.0),
    # F ran one budget: behind there, and no fit
    ({1000: 25.0}, _line(26, 1), "cannot fit", math.nan),
    ({1000: 25.0}, {3000: 24.0}, "cannot check", math.nan),
])
def test_the_crossing_of_f_and_another_method(f, other, outcome, steps):
    c = crossing(f, other)
    assert c.outcome == outcome
    assert c.steps == pytest.approx(steps, nan_ok=True)
    if outcome != "cannot check":
        assert c.largest == max(set(f) & set(other))
    if outcome == "crosses":
        assert c.steps <= HORIZON * c.largest and c.per_decade == pytest.approx(1.0)
        assert c.behind == (1000, 10000)


def test_a_difference_is_paired_by_seed_where_the_seeds_match():
    mean, se, rule = difference({0: 30.0, 1: 31.0, 2: 32.0}, {0: 29.0, 1: 29.5, 2: 31.0})
    # per-seed differences 1, 1.5, 1: mean 7/6, standard deviation sqrt(1/12), over sqrt(3)
    assert (mean, se) == pytest.approx((7 / 6, math.sqrt(1 / 12) / math.sqrt(3)))
    assert rule == "paired, 3 seeds"
    mean, se, rule = difference({0: 30.0, 1: 32.0}, {0: 29.0, 3: 31.0, 4: 30.0})
    assert (mean, se) == pytest.approx((1.0, math.sqrt(2.0 / 2 + 1.0 / 3))) and rule == "unpaired, 2/3 seeds"
    mean, se, rule = difference({0: 30.0, 1: 32.0}, {0: 29.0})  # one seed on a side: that seed's pair
    assert mean == pytest.approx(1.0) and math.isnan(se)
    assert rule == "paired on seed 0 of 2/1: no standard error"
    mean, se, rule = difference({0: 30.0, 1: 32.0}, {2: 29.0})  # no common seed: the means
    assert mean == pytest.approx(2.0) and math.isnan(se) and rule == "2/1 seeds: no standard error"
    mean, se, rule = difference({0: 30.0, 1: 31.0, 2: 35.0}, {0: 29.0, 1: 29.5})  # the common seeds, paired
    assert (mean, se) == pytest.approx((1.25, 0.25)) and rule == "paired, 2 seeds of 3/2"
    assert math.isnan(difference({}, {0: 29.0})[0])


def _gap(pair: tuple[str, str], data: str, scenes: int, steps: int, mean: float, se: float = 0.2) -> Finding:
    return Finding("scaling_gap", "holds" if mean > 0 else "does not hold", "psnr", "dB", pair,
                   {"mean": mean, "se": se, "flip mean": math.nan, "flip se": math.nan}, 4.0,
                   detail={"data": data, "train_scenes": scenes, "steps": steps, "rule": "paired, 3 seeds",
                           "seeds": dict.fromkeys(pair, "0,1,2"), "claim": "F above"})


def test_f_without_sa_is_measured_against_f_where_row_e_ran():
    """Row E (F without semantic alignment) is the issue's fourth diagnostic: ``E - F`` is listed, paired by
    seed, at the scale points where E ran, and nowhere else."""
    psnr = {("F", 0): 27.0, ("F", 1): 26.5, ("F", 2): 27.5, ("E", 0): 26.0, ("E", 1): 26.1, ("E", 2): 26.9}
    points = pd.DataFrame([{"data": "small", "train_scenes": 5, "steps": 3000, "experiment": e, "seed": s,
                            "psnr": v, "flip": 0.1} for (e, s), v in psnr.items()]
                          + [{"data": "small", "train_scenes": 5, "steps": 1000, "experiment": "F", "seed": 0,
                              "psnr": 25.0, "flip": 0.2}])
    table = scaling_gaps.table(Grid(points), [("small", 1000), ("small", 3000)])
    e_rows = table[(table["a"] == "E") & (table["b"] == "F")]
    (row,) = e_rows.to_dict("records")
    d = [psnr["E", s] - psnr["F", s] for s in range(3)]
    assert row["steps"] == 3000 and row["rule"] == "paired, 3 seeds"
    assert row["PSNR dB"] == pytest.approx(sum(d) / 3)
    assert row["PSNR se"] == pytest.approx(pd.Series(d).std(ddof=1) / math.sqrt(3))
    (found,) = [f for f in scaling_gaps.findings(table) if f.subjects == ("E", "F")]
    assert found.verdict == "measured"



def test_the_differences_figure_draws_the_rows_with_runs_on_both_sides(tmp_path):
    """``scaling_gaps.png`` draws each difference with runs on both sides (a cell without runs is a row of the
    table, not a point), and writes nothing when no difference has both sides."""
    from mcd.reporting.provenance import Provenance
    from mcd.reporting.scaling import gaps_plot

    psnr = {("F", 0): 27.0, ("F", 1): 26.5, ("ntasad", 0): 28.0, ("ntasad", 1): 28.9, ("A", 0): 25.0}
    points = pd.DataFrame([{"data": "small", "train_scenes": 5, "steps": 3000, "experiment": e, "seed": s,
                            "psnr": v, "flip": 0.1} for (e, s), v in psnr.items()])
    table = scaling_gaps.table(Grid(points), [("small", 3000), ("medium", 3000)])
    drawn = gaps_plot.rows(table)
    assert len(table) == 4 and drawn["difference"].tolist() == ["Ours (F) - NTASAD", "Ours (F) - A"]
    prov = Provenance.gather([], [], command="test")
    assert gaps_plot.write(table, tmp_path, prov) == tmp_path / gaps_plot.FILE
    assert (tmp_path / gaps_plot.FILE).stat().st_size > 10_000
    assert gaps_plot.write(table[table["data"] == "medium"], tmp_path / "none", prov) is None
    assert not (tmp_path / "none").exists()


def test_a_difference_says_when_its_two_sides_ran_different_code():
    """The gaps table's ``code``: ``same`` where one commit trained every run of both cells; else each side's
    commits (a cell resumed under a second commit, or of two commits, shows them), so a difference across code
    is not read as the methods' alone. The cells table has the same column."""
    from mcd.reporting.scaling.grid import cells

    rows = [("F", 0, "954f1b4", 27.06), ("F", 1, "75caca1", 26.79), ("ntasad", 0, "954f1b4", 29.42),
            ("ntasad", 1, "75caca1+f3b1d0d", 29.34), ("A", 0, "4eb66cd", 25.65), ("A", 1, "4eb66cd", 25.5),
            ("C", 0, "4eb66cd", 26.7), ("C", 1, "4eb66cd", 26.6)]
    points = pd.DataFrame([{"data": "tiny", "train_scenes": 2, "steps": 1000, "experiment": e, "seed": s,
                            "psnr": v, "flip": 0.1, "psnr_train": v, "train_steps": 1000,
                            "stop_reason": "max_steps", "code": c} for e, s, c, v in rows])
    table = scaling_gaps.table(Grid(points), [("tiny", 1000)]).set_index("difference")["code"]
    assert table[f"{display_name('F')} - {display_name('ntasad')}"] == \
        f"{display_name('F')}: 954f1b4; 75caca1, {display_name('ntasad')}: 954f1b4; 75caca1+f3b1d0d"
    assert scaling_gaps.code_pair(Grid(points), "tiny", 1000, "A", "C") == "same"
    assert scaling_gaps.code_pair(Grid(points), "tiny", 1000, "A", "E") == ""  # no runs of E
    assert dict(zip(cells(Grid(points))["experiment"], cells(Grid(points))["code"], strict=True))["F"] == \
        "954f1b4; 75caca1"

def test_the_viewer_shows_the_largest_budget_where_the_most_methods_ran():
    """The viewer's scale point is the largest data profile's largest budget among those where the most
    methods ran: one method alone at a larger budget does not move it there; once another joins, it does."""
    def grid(cells: list[tuple[str, int, str]]) -> Grid:
        scenes = {"small": 5, "medium": 12}
        return Grid(pd.DataFrame([{"data": d, "train_scenes": scenes[d], "steps": s, "experiment": e,
                                   "seed": 0, "psnr": 27.0, "flip": 0.1} for d, s, e in cells]))

    shared = [(d, s, e) for d in ("small", "medium") for s in (1000, 3000) for e in ("F", "ntasad")]
    assert grid(shared).viewer_point() == ("medium", 3000)
    assert grid([*shared, ("medium", 10000, "F")]).viewer_point() == ("medium", 3000)
    joined = [*shared, ("medium", 10000, "F"), ("medium", 10000, "ntasad")]
    assert grid(joined).viewer_point() == ("medium", 10000)
    assert grid([("small", 1000, "F"), ("small", 3000, "A")]).viewer_point() == ("small", 3000)
    assert Grid(pd.DataFrame()).viewer_point() is None


@pytest.mark.parametrize("signs, words", [
    ((-1, -1, +1, +1), "It appears as the work grows"),
    ((+1, +1, +1, +1), "Yes: the paper's ordering"),
    ((-1, -1, -1, -1), "No, not within the grid measured"),
    ((+1, +1, +1, -1), "No, it fades as the work grows"),
    ((-1, +1, +1, -1), "Partly"),
])
def test_the_answer_follows_the_ordering_from_the_smallest_to_the_largest_scale_point(signs, words):
    points = [("tiny", 2, 1000), ("tiny", 2, 10000), ("small", 5, 1000), ("small", 5, 10000)]
    found = [_gap(pair, d, n, s, sign * 1.5) for (d, n, s), sign in zip(points, signs, strict=True)
             for pair in (("F", "ntasad"), ("F", "A"))]
    text = notes.answer(found)
    assert words in text
    # the smallest and the largest scale point's F - NTASAD, with their standard errors
    assert f"{signs[0] * 1.5:+.2f} ± 0.20 dB" in text and "tiny x 1000 steps" in text
    assert "small x 10000 steps" in text
    assert "not yet a result" not in text  # 1.5 dB at 0.2 standard error: resolved
    shaky = notes.answer([*found[:-2], _gap(("F", "ntasad"), "small", 5, 10000, signs[-1] * 1.5, se=1.0)])
    assert "the seeds do not resolve the sign of Ours (F) - NTASAD at small x 10000 steps" in shaky
    assert "cannot be answered" in notes.answer([])


def test_the_answer_follows_f_minus_ntasad_along_each_axis_apart():
    """notes.trends: over the budgets of each data profile and over the data at each budget, first to last
    with the points between; a one-seed point is marked; an axis of one point gives no sentence."""
    by = {(d, n, s): _gap(("F", "ntasad"), d, n, s, m, se=se) for d, n, s, m, se in [
        ("tiny", 2, 1000, -2.27, 0.19), ("tiny", 2, 3000, -0.75, math.nan),
        ("small", 5, 1000, -2.25, math.nan)]}
    (text,) = notes.trends({(n, d, s): f for (d, n, s), f in by.items()})
    assert "over steps on tiny it narrows, -2.27 (1000 steps) -> -0.75 (3000 steps, one seed)" in text
    assert "over data at 1000 steps it narrows, -2.27 (tiny) -> -2.25 (small, one seed)" in text
    assert "3000 steps it" not in text and "over steps on small" not in text
    assert notes.trends({(2, "tiny", 1000): by["tiny", 2, 1000]}) == []
    assert "Along each axis apart" in notes.answer(list(by.values()))


def test_the_notes_name_the_input_that_carries_ntasads_lead():
    """notes.lead: at a scale point with F - NTASAD and NTASAD's diagnostics, the costliest resolved removal
    is named with its share of F's gap, what was given to F follows, and an unresolved cost names nothing."""
    point = ("tiny", 2, 1000)
    found = [_gap(("F", "ntasad"), *point, -2.0), _gap(("ntasad_no_warp", "ntasad"), *point, -0.5),
             _gap(("ntasad_no_previous", "ntasad"), *point, -1.0),
             _gap(("F_warp_previous", "F"), *point, 0.1, se=0.4),
             _gap(("F", "ntasad"), "small", 5, 1000, -1.0)]
    (text,) = notes.lead(found)  # small has no diagnostic: no paragraph
    assert "At tiny x 1000 steps, Ours (F) - NTASAD = -2.00 ± 0.20 dB" in text
    assert "The costliest removal, NTASAD, no previous output (diagnostic) (-1.00 dB, 50% of F's gap)" in text
    assert "NTASAD, no warp (diagnostic): -0.50 ± 0.20 dB" in text
    assert "Given to F: F + warped previous output (not the paper's) - Ours (F) = +0.10 ± 0.40 dB" in text
    (shaky,) = notes.lead([found[0], _gap(("ntasad_no_warp", "ntasad"), *point, -0.5, se=0.5)])
    assert "costliest" not in shaky and "none of the inputs switched off is shown to carry" in shaky
    assert notes.lead(found[:1]) == []



def test_the_notes_say_what_each_of_fs_additions_is_worth():
    """notes.additions: at a scale point where F_paper_<part> ran, each addition's worth to F (minus
    ``F_paper_<part> - F``) from the most to the least, all put back at once beside them, the resolved gains
    and losses named, a one-seed part called a lead; no paragraph where no part ran."""
    point = ("tiny", 2, 1000)
    found = [_gap(("F_paper_output", "F"), *point, -0.9), _gap(("F_paper_head", "F"), *point, 0.6),
             _gap(("F_paper_edge", "F"), *point, -0.1, se=math.nan), _gap(("F_paper", "F"), *point, -1.6),
             _gap(("F_paper", "F"), "small", 5, 1000, -1.0)]
    (text,) = notes.additions(found)  # small has F_paper only: no paragraph
    worth = text[text.index("worth to F"):]
    out, edge, head = (worth.index(display_name(e)) for e in ("F_paper_output", "F_paper_edge",
                                                                "F_paper_head"))
    assert out < edge < head  # from the most to the least worth
    assert f"{display_name('F_paper_output')}: +0.90 ± 0.20 dB (paired, 3 seeds; 4.5 standard errors" in text
    assert f"{display_name('F_paper_head')}: -0.60 ± 0.20 dB (paired, 3 seeds; 3.0 standard errors" in text
    assert f"{display_name('F_paper_edge')}: +0.10 dB (paired, 3 seeds)" in text
    assert "All put back at once (Ours (F, paper's text) - F): -1.60 ± 0.20 dB" in text
    assert f"Resolved gains (2 standard errors): {display_name('F_paper_output')}; resolved losses: " \
           f"{display_name('F_paper_head')}; the rest are leads" in text
    assert notes.additions(found[3:]) == []

def test_the_plan_is_the_sweeps_grid_less_the_seeds_it_drops():
    plan = coverage.planned()
    assert len(plan) == 5 * (9 + 2 * 2)
    seeds = plan.groupby(["data", "steps"])["seed"].apply(lambda s: sorted(set(s)))
    assert seeds["small", 3000] == [0, 1, 2] and seeds["tiny", 3000] == [0] and seeds["medium", 10000] == [0]


def _run(args: list[str], cwd: Path, returncode: int = 0) -> subprocess.CompletedProcess:
    """``python -m <module> <args>`` (``args`` starting ``-m <module>``) in the worker."""
    assert args[0] == "-m", args
    proc = command_in_worker(args[1], args[2:], cwd, {"OMP_NUM_THREADS": "1"})
    assert proc.returncode == returncode, f"{args}\n{proc.stdout[-3000:]}\n{proc.stderr[-5000:]}"
    return proc


@pytest.mark.slow
def test_a_real_grid_gives_the_scaling_report(cbox_store, tmp_path):
    """F, NTASAD and row A at 2 and 4 real steps on the 32x32 Cornell box, seeds 0 and 1 at 4 steps: the
    report's figure, its cells and differences against the runs' metrics.json, its findings, the missing legs
    of the sweep's plan, and the viewer of the largest scale point."""
    sweep = tmp_path / "sweep"
    _run(["-m", "mcd.run", "-m", "+sweep=scaling", "+experiment=F,ntasad,A", "train.max_steps=2,4",
          "seed=0,1",
          "sweep_plan.seeds_only_where={data:[tiny],train.max_steps:[4]}",
          *store32_overrides(cbox_store[1].data_dir), "train.batch_size=1", "train.val_every_steps=2",
          "trainer.enable_progress_bar=false", f"hydra.sweep.dir={sweep}"], tmp_path)
    # a job of the plan (tiny, 1000 steps, row A) that fails before any work: recorded, and listed as failed
    _run(["-m", "mcd.run", "-m", "+sweep=scaling", "+experiment=A", "train.max_steps=1000", "train.lr=-1",
          *store32_overrides(cbox_store[1].data_dir), f"hydra.sweep.dir={sweep}"], tmp_path, returncode=1)
    assert (sweep / "tiny" / "A_steps1000_seed0" / "error.json").is_file()
    runs = {}
    for done in sorted(sweep.glob("tiny/*/metrics.json")):  # <experiment>_steps<steps>_seed<seed>/
        job = done.parent
        exp, steps, seed = re.fullmatch(r"(\w+)_steps(\d+)_seed(\d+)", job.name).groups()
        runs[exp, int(steps), int(seed)] = json.loads((job / "metrics.json").read_text())
    cells_run = ((2, [0]), (4, [0, 1]))
    assert sorted(runs) == sorted((e, s, x) for e in ("A", "F", "ntasad") for s, seeds in cells_run
                                  for x in seeds)

    from mcd.report import main

    main([str(sweep), "--out", str(tmp_path / "reports"), "--readme", str(tmp_path / "README.md")])
    out = tmp_path / "reports" / "scaling"  # a scaling sweep's runs make a scaling report by themselves
    assert (out / "scaling.png").stat().st_size > 20_000
    assert (out / "scaling_gaps.png").stat().st_size > 20_000
    assert "![scaling_gaps.png](scaling_gaps.png)" in (out / "scaling_gaps.md").read_text()
    # every file of the report, the figure and the viewer included, is one its writers declare
    assert {p.name for p in out.iterdir()} == {*outputs.declared("scaling"), *outputs.declared("both")}

    cells = pd.read_csv(out / "scaling_cells.csv")
    for exp in ("F", "ntasad", "A"):
        for steps, seeds in cells_run:
            row = cells[(cells["data"] == "tiny") & (cells["steps"] == steps) & (cells["experiment"] == exp)]
            (r,) = row.to_dict("records")
            psnr = [runs[exp, steps, s]["psnr"] for s in seeds]
            flip = [runs[exp, steps, s]["flip"] for s in seeds]
            assert r["n"] == len(seeds) and str(r["seeds"]) == ",".join(map(str, seeds))
            assert r["psnr mean"] == pytest.approx(sum(psnr) / len(psnr))
            assert r["flip mean"] == pytest.approx(sum(flip) / len(flip))
            assert r["band"] == ("range" if len(seeds) == 2 else "none")
            assert (r["psnr lo"], r["psnr hi"]) == pytest.approx((min(psnr), max(psnr)))
    empty = cells[(cells["data"] == "medium") & (cells["steps"] == 10000) & (cells["experiment"] == "F")]
    assert empty["n"].tolist() == [0] and empty["band"].tolist() == ["no runs"]

    gaps = pd.read_csv(out / "scaling_gaps.csv")

    def gap(steps: int, b: str) -> dict:
        (r,) = gaps[(gaps["data"] == "tiny") & (gaps["steps"] == steps) & (gaps["a"] == "F")
                    & (gaps["b"] == b)].to_dict("records")
        return r

    d = [runs["F", 4, s]["psnr"] - runs["ntasad", 4, s]["psnr"] for s in (0, 1)]
    r = gap(4, "ntasad")
    assert r["rule"] == "paired, 2 seeds" and r["PSNR dB"] == pytest.approx(sum(d) / 2)
    assert r["PSNR se"] == pytest.approx(abs(d[0] - d[1]) / 2)
    r = gap(2, "A")
    assert r["PSNR dB"] == pytest.approx(runs["F", 2, 0]["psnr"] - runs["A", 2, 0]["psnr"])
    assert math.isnan(r["PSNR se"]) and "no standard error" in r["rule"]
    assert r["FLIP"] == pytest.approx(runs["F", 2, 0]["flip"] - runs["A", 2, 0]["flip"])
    at = gaps[(gaps["data"] == "medium") & (gaps["steps"] == 10000) & (gaps["b"] == "ntasad")]
    (missing,) = at.to_dict("records")
    assert missing["a seeds"] == "none" and missing["rule"] == "no runs of Ours (F) or NTASAD"

    found = finding.read(out / "findings.json")
    kinds = {f.kind for f in found}
    assert {"scaling_coverage", "scaling_gap", "scaling_fit", "scaling_crossing", "sampling_map_health"} <= \
        kinds

    def means(exp: str) -> dict[int, float]:
        return {s: sum(runs[exp, s, x]["psnr"] for x in seeds) / len(seeds) for s, seeds in cells_run}

    (fit_f,) = [f for f in found if f.kind == "scaling_fit" and f.subjects == ("F",)]
    assert fit_f.values["b"] == pytest.approx((means("F")[4] - means("F")[2]) / math.log10(2))
    (cross,) = [f for f in found if f.kind == "scaling_crossing" and f.subjects == ("F", "ntasad")]
    assert cross.detail["outcome"] == crossing(means("F"), means("ntasad")).outcome

    jobs = pd.read_csv(out / "scaling_jobs.csv")
    assert (jobs["status"] == "outside the plan").sum() == 9  # the test's budgets are not the plan's
    assert (jobs["status"] == "not run").sum() == 64
    failed = jobs[(jobs["data"] == "tiny") & (jobs["steps"] == 1000) & (jobs["experiment"] == "A")]
    assert failed["status"].tolist() == ["failed"]
    text = (out / "notes.md").read_text()
    assert "Does the paper's ordering appear as the work grows?" in text.split("\n\n")[2]
    assert f"{sum(d) / 2:+.2f} ± {abs(d[0] - d[1]) / 2:.2f} dB (paired, 2 seeds" in text
    assert "- medium, 10000 steps: Ours (F), seed 0 (not run)" in text
    assert "- small, 3000 steps: NTASAD, seeds 0, 1, 2 (not run)" in text
    assert "- tiny, 1000 steps: A, seed 0 (failed)" in text
    readme = (out / "README.md").read_text()
    assert "- Data profile(s): tiny" in readme
    assert "the largest scale point the methods share, tiny x 4 steps" in readme
    assert "A_steps1000_seed0`: failed: ConfigError: train.lr=-1" in readme
    # the viewer shows the largest scale point's runs: F's pictures carry F_steps4_seed0's per-frame PSNR
    data = json.loads((out / "viewer" / "data.js").read_text().split(" = ", 1)[1].rstrip().rstrip(";"))
    first = data["frames"][0]
    shown = {i["key"]: i["metrics"]["psnr"] for i in first["images"]}
    frames = pd.read_csv(sweep / "tiny" / "F_steps4_seed0" / "frames.csv")
    want = frames[(frames["scene"] == first["scene"]) & (frames["frame"] == first["frame"])]["psnr"].item()
    assert shown["F"] == pytest.approx(want) and {"ntasad", "noisy", "reference"} <= set(shown)
    assert "| scaling |" in (tmp_path / "reports" / "README.md").read_text()  # the reports index lists it

    # the run records alone regenerate the same tables (the viewer, which needs samples, is left as it was)
    main([str(out / "runs"), "--name", "scaling", "--out", str(tmp_path / "reports"), "--readme",
          str(tmp_path / "README.md")])
    pd.testing.assert_frame_equal(pd.read_csv(out / "scaling_cells.csv"), cells)
    pd.testing.assert_frame_equal(pd.read_csv(out / "scaling_gaps.csv"), gaps)

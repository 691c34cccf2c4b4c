"""The scaling report's generated ``notes.md`` (docs/benchmark.md "Scaling report"): a first paragraph that
answers "Does the paper's ordering appear as the work grows?", then what the grid covers and what is missing,
the differences, fits and crossings, and the sampling-map flags. Every sentence is made from the report's
findings (:mod:`mcd.reporting.finding` records, ``findings.json``), never typed: the file is rewritten by
every run of the report, and a hand-written analysis goes in a file of its own beside it (:data:`ANALYSIS`).

The answer's rule, from the ``scaling_gap`` findings of F - NTASAD and F - U-Net (row A) at each scale
point (a data profile and a step budget), the scale points ordered by training scenes, then data name, then
steps:

- no scale point with F and NTASAD or the U-Net: the question cannot be answered yet;
- the ordering (F above both where both ran) holds at every scale point: yes, at every one measured;
- it holds at the largest scale point and not at the smallest: it appears as the work grows;
- it holds at the smallest and not at the largest: no, it fades as the work grows;
- it holds at none: no, within the grid measured (with the crossings of the fits);
- else: partly, naming where it holds.

Then how F - NTASAD moves along each axis apart (:func:`trends`): over the budgets of each data profile, and
over the data profiles at each budget. The verdict goes by the means; where the seeds do not resolve the
sign of a difference it rests on (at the smallest or the largest scale point: fewer than ``RESOLVED_SE``
standard errors from zero, or no standard error), the paragraph says so.

Which of NTASAD's inputs carries its lead (:func:`lead`), at each scale point with F - NTASAD and at least one
of NTASAD's diagnostics (``mcd.config.methods``: a ``diagnostic`` variant of ``ntasad``, each switching one
input off): each diagnostic's cost to NTASAD with its standard error; the input whose removal costs most,
among the resolved costs, carries the most of the lead, stated as a share of F's gap (each diagnostic removes
one input from the whole NTASAD, so the costs need not add up to the gap); then what the same input does for
F where it was given to F (:data:`GIVEN_TO_F`).
"""

from __future__ import annotations

import math
from pathlib import Path

from mcd.config.methods import BY_EXPERIMENT, display_name
from mcd.reporting.finding import RESOLVED_SE, Finding, render, resolved
from mcd.reporting.markdown_text import escape as esc
from mcd.reporting.outputs import writes
from mcd.reporting.scaling.fit import HORIZON
from mcd.reporting.scaling.gaps import MAIN

#: The generated notes, the scaling report's (mcd.reporting.outputs); a report removes a stale one only where
#: it is generated (its first line is mcd.report.GENERATED_NOTES), never the user's own.
FILE, = writes("scaling", "notes.md")
#: The hand-written analysis a person may add beside the generated notes; the report never writes it.
ANALYSIS = "analysis.md"


#: F's variants that give F an input of NTASAD's: whether the input that carries NTASAD's lead helps F too.
GIVEN_TO_F = ("F_warp_previous",)
#: F with one of its additions put back to the paper's text (``conf/experiment/F_paper_<part>.yaml``;
#: docs/method.md "F against the paper"), and F with all of them put back.
PAPER_PARTS = tuple(e for e in BY_EXPERIMENT if e.startswith("F_paper_"))
PAPER_ALL = "F_paper"


def _point(f: Finding) -> tuple[int, str, int]:
    return f.detail["train_scenes"], f.detail["data"], f.detail["steps"]


def _where(point: tuple[int, str, int]) -> str:
    return f"{point[1]} x {point[2]} steps"


def _gap(f: Finding, sign: float = 1.0) -> str:
    """A difference's finding as the notes write it (``sign`` -1: minus it, what a put-back part is worth)."""
    m, se = sign * f.values["mean"], f.values["se"]
    if math.isnan(se):
        return f"{m:+.2f} dB ({f.detail['rule']})"
    return f"{m:+.2f} ± {se:.2f} dB ({f.detail['rule']}; {resolved(m, se)})"


def _short_crossing(f: Finding) -> str:
    v, d = f.values, f.detail
    steps = v["crossing steps"]
    return {"ahead": "F already ahead at every budget",
            "crossed": f"the fits cross at {steps:.3g} steps, within the budgets run",
            "crosses": f"the fits cross at {steps:.3g} steps ({steps / v['largest budget']:.1f}x the largest "
                       "budget, an extrapolation)",
            "no crossing": f"no crossing within {d['horizon']:g}x the largest budget",
            "losing": "F above at the largest budget by the fits, but losing ground",
            "cannot fit": "no fit (fewer than two budgets)",
            "cannot check": "no budget with both"}[d["outcome"]]


def _covered(coverage: Finding) -> str:
    """The plan's counts and the scale points with runs, from the ``scaling_coverage`` finding."""
    v, d = coverage.values, coverage.detail
    cells = "; ".join(f"{c['data']} x {c['steps']} steps ({', '.join(map(display_name, c['experiments']))})"
                      for c in d["cells"]) or "none"
    return (f"Planned by {d['sweep_file']}: {int(v['planned'])} jobs, of which {int(v['finished'])} "
            f"finished, {int(v['failed'])} failed, {int(v['incomplete'])} incomplete and {int(v['not run'])} "
            f"not run; {int(v['outside the plan'])} finished run(s) outside the plan. Scale points with "
            "runs: "
            f"{cells}.")


def _is_resolved(f: Finding) -> bool:
    se = f.values["se"]
    return not math.isnan(se) and se > 0 and abs(f.values["mean"]) >= RESOLVED_SE * se


def lead(found: list[Finding]) -> list[str]:
    """One paragraph per scale point with F - NTASAD and a diagnostic of NTASAD's (module docstring)."""
    main, rival = MAIN[0]
    gaps = [f for f in found if f.kind == "scaling_gap"]
    out = []
    for point, gap in sorted((_point(f), f) for f in gaps if f.subjects == MAIN[0]):
        here = [f for f in gaps if _point(f) == point]
        removed = sorted((f for f in here if f.subjects[1] == rival and f.subjects[0] in BY_EXPERIMENT
                          and BY_EXPERIMENT[f.subjects[0]].diagnostic), key=lambda f: f.values["mean"])
        if not removed:
            continue
        text = [f"At {_where(point)}, {display_name(main)} - {display_name(rival)} = {_gap(gap)}. Each "
                f"diagnostic against {display_name(rival)}: " +
                "; ".join(f"{display_name(f.subjects[0])}: {_gap(f)}" for f in removed) + "."]
        costly = [f for f in removed if f.values["mean"] < 0 and _is_resolved(f)]
        if costly:
            top, lost = costly[0], -gap.values["mean"]
            share = (f", {-top.values['mean'] / lost:.0%} of F's gap" if lost > 0 else
                     f", while F is above {display_name(rival)} here")
            cost = f"{top.values['mean']:+.2f} dB{share}"
            text.append(f"The costliest removal, {display_name(top.subjects[0])} ({cost}), marks the input "
                        f"that carries the most of {display_name(rival)}'s lead measured here; each "
                        "diagnostic removes one input from the whole method, so the costs need not add up to "
                        "the gap.")
        else:
            text.append(f"No diagnostic's cost is resolved by these seeds, so none of the inputs switched "
                        f"off is shown to carry {display_name(rival)}'s lead here.")
        given = [f for f in here if f.subjects[1] == main and f.subjects[0] in GIVEN_TO_F]
        text += [f"Given to F: {display_name(f.subjects[0])} - {display_name(main)} = {_gap(f)}."
                 for f in given]
        out.append(" ".join(text))
    return out


def additions(found: list[Finding]) -> list[str]:
    """One paragraph per scale point where an ``F_paper_<part>`` ran: what each of F's additions to the
    paper's text is worth there (minus ``F_paper_<part> - F``), from the most to the least, each with its
    standard error, and beside them ``F_paper - F``, all of them put back at once (the parts need not add up
    to it: each is put back alone into the whole F)."""
    gaps = [f for f in found if f.kind == "scaling_gap" and f.subjects[1] == "F"]
    out = []
    for point in sorted({_point(f) for f in gaps if f.subjects[0] in PAPER_PARTS}):
        here = {f.subjects[0]: f for f in gaps if _point(f) == point}
        parts = sorted((here[e] for e in PAPER_PARTS if e in here), key=lambda f: f.values["mean"])
        worth = [f"{display_name(f.subjects[0])}: {_gap(f, -1.0)}" for f in parts]
        helps = [display_name(f.subjects[0]) for f in parts if f.values["mean"] < 0 and _is_resolved(f)]
        hurts = [display_name(f.subjects[0]) for f in parts if f.values["mean"] > 0 and _is_resolved(f)]
        text = [f"At {_where(point)}, what each addition is worth to F (F minus F with it put back): "
                + "; ".join(worth) + "."]
        if PAPER_ALL in here:
            text.append(f"All put back at once ({display_name(PAPER_ALL)} - F): {_gap(here[PAPER_ALL])}.")
        rest = "." if all(_is_resolved(f) for f in parts) else "; the rest are leads, not results."
        text.append(f"Resolved gains ({RESOLVED_SE:g} standard errors): {', '.join(helps) or 'none'}; "
                    f"resolved losses: {', '.join(hurts) or 'none'}{rest}")
        out.append(" ".join(text))
    return out


def _seeds(f: Finding) -> str:
    return "" if not math.isnan(f.values["se"]) else ", one seed"


def trends(by: dict[tuple[int, str, int], Finding]) -> list[str]:
    """One sentence on how F - NTASAD (``by``: its finding at each scale point) moves along each axis of the
    work apart: over the budgets of each data profile, and over the data profiles at each budget, each from
    its first to its last point, with the points in between; empty where no axis has two points."""
    def path(points: list[tuple[int, str, int]], label) -> str:
        steps = " -> ".join(f"{by[p].values['mean']:+.2f} ({label(p)}{_seeds(by[p])})" for p in points)
        first, last = by[points[0]].values["mean"], by[points[-1]].values["mean"]
        return f"{'narrows' if last > first else 'does not narrow'}, {steps}"

    axes = []
    for data in dict.fromkeys(p[1] for p in sorted(by)):
        line = sorted(p for p in by if p[1] == data)
        if len(line) > 1:
            axes.append(f"over steps on {data} it {path(line, lambda p: f'{p[2]} steps')}")
    for steps in sorted({p[2] for p in by}):
        line = sorted(p for p in by if p[2] == steps)
        if len(line) > 1:
            axes.append(f"over data at {steps} steps it {path(line, lambda p: p[1])}")
    if not axes:
        return []
    return [f"Along each axis apart, F's gap to {display_name(MAIN[0][1])} (dB): {'; '.join(axes)}."]


def answer(found: list[Finding]) -> str:
    """The first paragraph of ``notes.md`` (module docstring), from ``found`` alone."""
    coverage = next((f for f in found if f.kind == "scaling_coverage"), None)
    parts = []
    if coverage is not None:
        v = coverage.values
        beyond = f", and {int(v['outside the plan'])} run(s) outside it" if v["outside the plan"] else ""
        parts.append(f"This grid holds {int(v['finished'])} of the {int(v['planned'])} jobs the sweep plans "
                     f"({coverage.detail['sweep_file']}){beyond}" +
                     (f"; {int(v['planned'] - v['finished'])} planned jobs are missing (listed below)."
                      if v["planned"] > v["finished"] else "; none is missing."))
    gaps = {pair: {_point(f): f for f in found if f.kind == "scaling_gap" and f.subjects == pair}
            for pair in MAIN}
    points = sorted({p for by in gaps.values() for p in by})
    if not points:
        parts.append(f"No scale point has F beside {display_name('ntasad')} or the {display_name('unet')} "
                     "(row A) yet, so the question cannot be answered from these runs.")
        return " ".join(parts)
    for (a, b), by in gaps.items():
        name = f"{display_name(a)} - {display_name(b)}"
        if not by:
            parts.append(f"{name}: no scale point has both.")
            continue
        low, high = min(by), max(by)
        if low == high:
            parts.append(f"{name} at the only scale point with both, {_where(low)}: {_gap(by[low])}.")
        else:
            parts.append(f"{name}: {_gap(by[low])} at the smallest scale point with both ({_where(low)}), "
                         f"{_gap(by[high])} at the largest ({_where(high)}).")
    crossings = [f for f in found if f.kind == "scaling_crossing" and f.subjects == MAIN[0]]
    if crossings:
        parts.append(f"Fitting PSNR = a + b log10(steps) per method, F against {display_name(MAIN[0][1])}: " +
                     "; ".join(f"{f.detail['data']}: {_short_crossing(f)}" for f in crossings) + ".")

    def holds(p: tuple[int, str, int]) -> bool:
        return all(by[p].values["mean"] > 0 for by in gaps.values() if p in by)

    where = [p for p in points if holds(p)]
    ordering = (f"the paper's ordering (F above {display_name('ntasad')} and the {display_name('unet')}, "
                "where each ran)")
    if len(where) == len(points):
        verdict = f"yes: {ordering} holds at every scale point measured ({len(points)})"
    elif holds(points[-1]) and not holds(points[0]):
        verdict = (f"it appears as the work grows: {ordering} holds at the largest scale point "
                   f"({_where(points[-1])}) and not at the smallest ({_where(points[0])}); it holds at "
                   f"{', '.join(map(_where, where))}")
    elif holds(points[0]) and not holds(points[-1]):
        verdict = (f"no, it fades as the work grows: {ordering} holds at the smallest scale point "
                   f"({_where(points[0])}) and not at the largest ({_where(points[-1])}); it holds at "
                   f"{', '.join(map(_where, where))}")
    elif not where:
        ahead = [f.detail["data"] for f in crossings if f.detail["outcome"] in ("crossed", "crosses")]
        reach = (f", and the fits reach it within {HORIZON:g}x the largest budget on {', '.join(ahead)} only"
                 if ahead else f", and the fits reach it within {HORIZON:g}x the largest budget on no data "
                 "profile" if crossings else "")
        verdict = (f"no, not within the grid measured: {ordering} holds at none of its {len(points)} scale "
                   f"points{reach}")
    else:
        verdict = (f"partly: {ordering} holds at {', '.join(map(_where, where))}, not at "
                   f"{', '.join(_where(p) for p in points if p not in where)}")
    parts.append(f"Does the paper's ordering appear as the work grows? {verdict[0].upper()}{verdict[1:]}.")
    parts += trends(gaps[MAIN[0]])
    shaky = [f"{display_name(f.subjects[0])} - {display_name(f.subjects[1])} at {_where(p)}"
             for p in dict.fromkeys((points[0], points[-1])) for by in gaps.values() if p in by
             for f in [by[p]] if not abs(f.values["mean"]) >= RESOLVED_SE * f.values["se"]]
    if shaky:
        parts.append(f"The verdict goes by the means; the seeds do not resolve the sign of "
                     f"{', '.join(shaky)} (fewer than {RESOLVED_SE:g} standard errors from zero, or one "
                     "seed), so it is not yet a result.")
    return " ".join(parts)


def write(found: list[Finding], out_dir: Path, regenerate: str) -> Path:
    """Write ``notes.md``: :func:`answer`, then every scaling finding rendered, grouped (module docstring)."""
    def listed(kind: str) -> list[str]:
        return [f"- {esc(render(f))}" for f in found if f.kind == kind]

    coverage = next((f for f in found if f.kind == "scaling_coverage"), None)
    missing = coverage.detail["missing"] if coverage is not None else []
    maps = [f for f in found if f.kind == "sampling_map_health"]
    flagged = [f for f in maps if f.verdict == "does not hold"]
    lines = [
        "# Scaling study: generated notes",
        "",
        f"Generated from this report's findings (`findings.json`) by `{regenerate}`, rewritten each time; a "
        f"hand-written analysis goes beside it in `{ANALYSIS}`, which the report never writes. The runs' "
        "commands, config, commits and machines: [README.md](README.md), \"Provenance\".",
        "",
        esc(answer(found)),
        "",
        "## What the grid covers",
        "",
        *([f"- {esc(_covered(coverage))}"] if coverage is not None else []),
        "",
        "Missing legs (planned, not finished):",
        "",
        *([esc(f"- {m['data']}, {m['steps']} steps: {display_name(str(m['experiment']))}, seed"
               f"{'s' if len(m['seeds']) > 1 else ''} {', '.join(map(str, m['seeds']))} ({m['status']})")
           for m in missing] or ["- none"]),
        "",
        "## Differences at each scale point",
        "",
        *(listed("scaling_gap") or ["- none: no scale point has two of the compared methods"]),
        "",
        f"## Which of {display_name(MAIN[0][1])}'s inputs carries its lead",
        "",
        *([esc(p) + "\n" for p in lead(found)] or
          [f"No scale point has F - {display_name(MAIN[0][1])} beside a diagnostic of "
           f"{display_name(MAIN[0][1])}'s yet.", ""]),
        "## What F's additions to the paper's text are worth",
        "",
        *([esc(p) + "\n" for p in additions(found)] or
          ["No scale point has F beside an F_paper_<part> (docs/method.md \"F against the paper\") yet.",
           ""]),
        "## Fits of PSNR against log10(steps), and crossings",
        "",
        *(listed("scaling_fit") + listed("scaling_crossing") or ["- none: no method ran two budgets"]),
        "",
        "## Sampling-map health of the adaptive-sampling runs",
        "",
        *([f"- {esc(render(f))}" for f in flagged] or
          [f"- no map is flagged collapsed or edge-bound ({len(maps)} run(s) with a map)"
           if maps else "- no run records a sampling map"]),
        "",
    ]
    path = out_dir / FILE
    path.write_text("\n".join(lines))
    return path

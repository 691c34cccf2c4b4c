"""Error against optimiser steps, fitted per method and data profile, and where two methods' fits cross
(docs/benchmark.md "Scaling report").

The fit: ``PSNR = a + b * log10(steps)`` by least squares through the cell means (one point per budget, the
mean over its seeds, so that a budget with three seeds weighs as much as one with one). ``b`` is the dB gained
per tenfold steps; the residual is the root mean square of the points' distances from the line, which is 0 by
construction with two budgets (the fit then checks nothing). PSNR is the log of the MSE, so the same line is
a power law of MSE in the steps, ``MSE ~ steps ** (-b / 10)``.

Where F and another method cross, :func:`crossing`, decided in this order:

- ``ahead``: F's mean is above the other's at every budget both ran (no fit needed);
- ``cannot check`` / ``cannot fit``: no budget with both, or one of them has fewer than two budgets;
- F gains more per decade than the other (``b_F > b_other``), the fits cross at ``s*``: ``crossed`` where F's
  fit is above at the largest budget both ran (``s*`` at or below it), ``crosses`` where ``s*`` is within
  :data:`HORIZON` times that budget (an extrapolation), else ``no crossing`` (within the horizon);
- F gains no more per decade: ``no crossing`` where F's fit is below at the largest budget, ``losing`` where
  it is above (F ahead by the fit there, but the other method closing in).

(:func:`crossings` says ``no runs`` for a data profile where either method has none.)
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import pandas as pd

from mcd.config.methods import display_name
from mcd.reporting.finding import Finding
from mcd.reporting.scaling.gaps import MAIN
from mcd.reporting.tables import TABLE1_BUDGET

#: A crossing further than this many times the largest budget measured counts as none.
HORIZON = 10.0


@dataclass(frozen=True)
class Fit:
    """``a + b * log10(steps)`` through the points at ``budgets``, their RMS residual ``rms`` (dB)."""

    a: float
    b: float
    rms: float
    budgets: tuple[int, ...]

    def at(self, steps: float) -> float:
        """The fitted value at ``steps``."""
        return self.a + self.b * math.log10(steps)


def fit_log_steps(means: Mapping[int, float]) -> Fit | None:
    """The least-squares fit of ``{steps: mean}`` (module docstring); None below two budgets."""
    points = sorted((int(s), float(v)) for s, v in means.items() if s > 0 and not math.isnan(v))
    if len(points) < 2:
        return None
    xs = [math.log10(s) for s, _ in points]
    ys = [v for _, v in points]
    mx, my = sum(xs) / len(xs), sum(ys) / len(ys)
    b = sum((x - mx) * (y - my) for x, y in zip(xs, ys, strict=True)) / sum((x - mx) ** 2 for x in xs)
    a = my - b * mx
    rms = math.sqrt(sum((y - a - b * x) ** 2 for x, y in zip(xs, ys, strict=True)) / len(xs))
    return Fit(a, b, rms, tuple(s for s, _ in points))


@dataclass(frozen=True)
class Crossing:
    """Where F's fit meets another method's (module docstring): ``outcome``, the steps ``steps`` where the
    fits cross (NaN where they do not cross ahead, or are not fitted), the largest budget both ran
    ``largest``, F's gain per decade less the other's ``per_decade``, and the budgets both ran at which F
    is not above (``behind``)."""

    outcome: str
    steps: float
    largest: float
    per_decade: float
    behind: tuple[int, ...] = ()


def crossing(first: Mapping[int, float], second: Mapping[int, float], horizon: float = HORIZON) -> Crossing:
    """Where the fit of ``first`` (``{steps: mean PSNR}``, F) crosses that of ``second`` (module
    docstring)."""
    common = sorted(set(first) & set(second))
    if not common:
        return Crossing("cannot check", math.nan, math.nan, math.nan)
    largest = common[-1]
    behind = tuple(s for s in common if not first[s] > second[s])
    f, o = fit_log_steps(first), fit_log_steps(second)
    per_decade = math.nan if f is None or o is None else f.b - o.b
    if not behind:
        return Crossing("ahead", math.nan, largest, per_decade)
    if f is None or o is None:
        return Crossing("cannot fit", math.nan, largest, per_decade, behind)
    above = f.at(largest) >= o.at(largest)
    if per_decade <= 0:
        return Crossing("losing" if above else "no crossing", math.nan, largest, per_decade, behind)
    steps = 10 ** ((o.a - f.a) / per_decade)
    outcome = "crossed" if above else "crosses" if steps <= horizon * largest else "no crossing"
    return Crossing(outcome, steps, largest, per_decade, behind)


def _means(cells: pd.DataFrame, data: str, experiment: str) -> dict[int, float]:
    if cells.empty:
        return {}
    df = cells[(cells["data"] == data) & (cells["experiment"] == experiment)]
    return {int(s): float(v) for s, v in zip(df["steps"], df["psnr mean"], strict=True) if not pd.isna(v)}


def fits(cells: pd.DataFrame, expected: list[tuple[str, str]]) -> pd.DataFrame:
    """One row per data profile and experiment of ``expected`` (the plan's and the runs'), from ``cells``
    (:func:`mcd.reporting.scaling.grid.cells`): its budgets, ``a``, ``b`` (dB per decade of steps), the RMS
    residual, and a note where the fit checks nothing (two budgets) or cannot be made (one, or no runs)."""
    rows = []
    for data, exp in expected:
        means = _means(cells, str(data), str(exp))
        f = fit_log_steps(means)
        note = ("no runs" if not means else "one budget: no fit" if f is None else
                "two budgets: the line passes through both (residual 0 by construction)"
                if len(f.budgets) == 2 else "")
        rows.append({"data": data, "experiment": exp, "method": display_name(str(exp)),
                     "budgets": ",".join(map(str, sorted(means))), "a dB": math.nan if f is None else f.a,
                     "b dB per decade": math.nan if f is None else f.b,
                     "rms residual dB": math.nan if f is None else f.rms, "note": note})
    return pd.DataFrame(rows, columns=["data", "experiment", "method", "budgets", "a dB", "b dB per decade",
                                       "rms residual dB", "note"])


def crossings(cells: pd.DataFrame, data: list[str]) -> list[tuple[str, str, str, Crossing]]:
    """``(data, first, second, crossing)`` of each pair of :data:`MAIN` on each data profile of ``data``;
    outcome ``no runs`` where either has no runs there."""
    out = []
    for d in data:
        for a, b in MAIN:
            first, second = _means(cells, d, a), _means(cells, d, b)
            c = crossing(first, second) if first and second else Crossing("no runs", *(math.nan,) * 3)
            out.append((d, a, b, c))
    return out


def findings(table: pd.DataFrame, crossed: list[tuple[str, str, str, Crossing]]) -> list[Finding]:
    """A ``scaling_fit`` finding per fitted row of :func:`fits`, and a ``scaling_crossing`` per crossing:
    ``holds`` where F is ahead or the fits meet within :data:`HORIZON` (``ahead``, ``crossed``,
    ``crosses``), ``does not hold`` where they do not, ``cannot check`` where they cannot be fitted; none
    where either method has no runs (``no runs``)."""
    found = []
    for r in table.itertuples(index=False):
        row = dict(zip(table.columns, r, strict=True))
        if pd.isna(row["a dB"]):
            continue
        found.append(Finding("scaling_fit", "measured", "psnr", "dB", (row["experiment"],),
                             {"a": float(row["a dB"]), "b": float(row["b dB per decade"]),
                              "rms": float(row["rms residual dB"])}, TABLE1_BUDGET,
                             detail={"data": row["data"],
                                     "budgets": [int(b) for b in row["budgets"].split(",")]}))
    for data, a, b, c in crossed:
        if c.outcome == "no runs":
            continue
        verdict = ("holds" if c.outcome in ("ahead", "crossed", "crosses") else
                   "cannot check" if c.outcome.startswith("cannot") else "does not hold")
        found.append(Finding("scaling_crossing", verdict, "psnr", "dB", (a, b),
                             {"crossing steps": c.steps, "largest budget": c.largest,
                              "per decade": c.per_decade}, TABLE1_BUDGET,
                             detail={"data": data, "outcome": c.outcome, "horizon": HORIZON,
                                     "behind": list(c.behind),
                                     "claim": f"{a} reaches {b} within {HORIZON:g}x the largest budget"}))
    return found

"""Differences between methods at each scale point of the scaling study (docs/benchmark.md "Scaling report").

The paper's ordering puts F above NTASAD and above the U-Net (row A): :data:`MAIN` pairs are listed at every
scale point of the plan and of the runs, a cell without runs saying so. The paper's F against ours
(``F_paper - F``), each diagnostic against its method (``ntasad_no_warp - ntasad``, ...) and F without SA
against F (row E, :data:`COMPONENT_DIAGNOSTICS`) follow where the first of the two ran.

The rule for a difference of PSNR (and FLIP) between two cells, :func:`difference`:

- the cells share at least two seeds: *paired* by seed over the seeds they share, the mean of the per-seed
  differences and its standard error (their sample standard deviation over ``sqrt(n)``); a seed only one
  side has is left out (the rule says how many each side has);
- one side has a single seed and the other has it too: that seed's difference, no standard error (a variant
  that changes only the test, such as F without its output steps, follows F's training exactly, so the
  same seed is the exact comparison, and another seed's mean would add the seeds' spread to it);
- else, at least two seeds on each side: the difference of the means, standard error
  ``sqrt(s_a^2/n_a + s_b^2/n_b)`` (*unpaired*);
- else the difference of the means, no standard error.

Each difference says which code trained each side (``code``: ``same`` where every run of both cells ran
one code, else each side's commits, :func:`mcd.reporting.scaling.grid.code_of`): the same seed under other
numerics takes another trajectory, so a difference across code mixes the methods' difference with the
code's, which the seeds' standard error does not hold.

A seed value gives two methods no randomness in common but their test frames (their weights and crops are
drawn in different orders), so pairing changes the estimate's spread little; it is the rule because it is the
exact one where seeds match.
"""

from __future__ import annotations

import math

import pandas as pd

from mcd.config.methods import BY_EXPERIMENT, display_name
from mcd.reporting.finding import Finding
from mcd.reporting.scaling.grid import Grid, by_seed, codes_at
from mcd.reporting.tables import TABLE1_BUDGET

#: The paper's ordering, checked at every scale point: (subject, the method it should be above).
MAIN = (("F", "ntasad"), ("F", "A"))
#: Pairs shown where their first experiment ran: each variant of F (the paper's F, the per-pixel identity
#: channel) and each diagnostic against its method (``mcd.config.methods``: ``variant_of``).
#: Component rows that answer a diagnostic of the F - NTASAD gap: row E is F without semantic alignment
#: (Sec. 4.4; docs/method.md "Diagnostics"), so ``E - F`` is minus what SA adds at a scale point.
COMPONENT_DIAGNOSTICS = (("E", "F"),)
EXTRA = (*((m.experiment, str(m.variant_of)) for m in BY_EXPERIMENT.values()
           if m.variant_of and (m.diagnostic or m.variant_of == "F")), *COMPONENT_DIAGNOSTICS)


def difference(a: dict[int, float], b: dict[int, float]) -> tuple[float, float, str]:
    """``a - b`` of two cells' ``{seed: score}``: mean, standard error (NaN where the rule gives none) and
    the rule applied (module docstring); NaN and ``no runs`` when a side is empty."""
    if not a or not b:
        return math.nan, math.nan, "no runs"
    common = sorted(set(a) & set(b))
    of = "" if set(a) == set(b) else f" of {len(a)}/{len(b)}"
    if len(common) >= 2:
        d = pd.Series([a[s] - b[s] for s in common])
        return float(d.mean()), float(d.std(ddof=1) / math.sqrt(len(d))), f"paired, {len(d)} seeds{of}"
    if common and min(len(a), len(b)) == 1:
        s = common[0]
        return a[s] - b[s], math.nan, f"paired on seed {s}{of}: no standard error"
    mean = sum(a.values()) / len(a) - sum(b.values()) / len(b)
    if len(a) >= 2 and len(b) >= 2:
        va, vb = pd.Series(list(a.values())).var(ddof=1), pd.Series(list(b.values())).var(ddof=1)
        return mean, float(math.sqrt(va / len(a) + vb / len(b))), f"unpaired, {len(a)}/{len(b)} seeds"
    return mean, math.nan, f"{len(a)}/{len(b)} seeds: no standard error"


def _seeds(cell: dict[int, float]) -> str:
    return ",".join(map(str, sorted(cell))) if cell else "none"


def table(grid: Grid, scale_points: list[tuple[str, int]]) -> pd.DataFrame:
    """One row per pair and scale point: :data:`MAIN` at each of ``scale_points`` (the plan's and the runs'),
    :data:`EXTRA` where its first experiment ran; columns ``data``, ``train scenes`` (of the profile's
    runs; empty without runs), ``steps``, ``difference``, the seeds of
    each side (``none`` where a cell has no runs), ``rule``, ``PSNR dB``, ``PSNR se``, ``FLIP``, ``FLIP se``
    (FLIP: lower is better, so a negative difference favours the first method)."""
    rows = []
    sizes = {d: grid.train_scene_count(d) for d in grid.data}
    for data, steps in scale_points:
        for a, b in (*MAIN, *EXTRA):
            pa, pb = by_seed(grid, data, steps, a), by_seed(grid, data, steps, b)
            if (a, b) in EXTRA and not pa:
                continue
            psnr, psnr_se, rule = difference(pa, pb)
            flip, flip_se, _ = difference(by_seed(grid, data, steps, a, "flip"),
                                          by_seed(grid, data, steps, b, "flip"))
            rows.append({"data": data, "train scenes": sizes.get(data), "steps": steps,
                         "difference": f"{display_name(a)} - {display_name(b)}", "a": a, "b": b,
                         "a seeds": _seeds(pa), "b seeds": _seeds(pb),
                         "rule": rule + stopped_early(grid, data, steps, (a, b)) if pa and pb
                         else "no runs of " + " or ".join(
                             display_name(e) for e, cell in ((a, pa), (b, pb)) if not cell),
                         "code": code_pair(grid, data, steps, a, b),
                         "PSNR dB": psnr, "PSNR se": psnr_se, "FLIP": flip, "FLIP se": flip_se})
    return pd.DataFrame(rows, columns=["data", "train scenes", "steps", "difference", "a", "b", "a seeds",
                                       "b seeds", "rule", "code", "PSNR dB", "PSNR se", "FLIP", "FLIP se"])


def code_pair(grid: Grid, data: str, steps: int, a: str, b: str) -> str:
    """``same`` where both cells' runs ran one code, else ``<a>: <its code>, <b>: <its code>`` (module
    docstring); empty where a cell has no runs."""
    ca, cb = codes_at(grid, data, steps, a), codes_at(grid, data, steps, b)
    if not ca or not cb:
        return ""
    if ca == cb and len(ca) == 1:
        return "same"
    return f"{display_name(a)}: {'; '.join(ca)}, {display_name(b)}: {'; '.join(cb)}"


def stopped_early(grid: Grid, data: str, steps: int, experiments: tuple[str, str]) -> str:
    """``; stopped early: <method> seed s at step t (why), ...`` for the runs of the two cells that trained
    fewer steps than the scale point's budget, or ``""``: a finding at a budget of 1500 steps was stated for
    runs stopped after 1 step (by ``train.epochs``), the cells table alone saying so."""
    p = grid.points
    if not {"train_steps", "stop_reason"} <= set(p.columns):  # a grid without the runs' budgets
        return ""
    parts = []
    for exp in experiments:
        df = p[(p["data"] == data) & (p["steps"] == steps) & (p["experiment"] == exp)]
        early = df[df["train_steps"].notna() & (df["train_steps"] < steps)]
        parts += [f"{display_name(exp)} seed {s} at step {int(t)} ({why})" for s, t, why in
                  zip(early["seed"], early["train_steps"], early["stop_reason"], strict=True)]
    return f"; stopped early: {', '.join(parts)}" if parts else ""


def findings(gaps: pd.DataFrame) -> list[Finding]:
    """One ``scaling_gap`` finding per row of :func:`table` with runs on both sides: for :data:`MAIN`, the
    claim that the first method is above the second (``holds`` / ``does not hold`` by the mean); the other
    pairs are ``measured``."""
    found = []
    for r in gaps.itertuples(index=False):
        if pd.isna(r[gaps.columns.get_loc("PSNR dB")]):
            continue
        row = dict(zip(gaps.columns, r, strict=True))
        a, b, mean = row["a"], row["b"], float(row["PSNR dB"])
        verdict = ("holds" if mean > 0 else "does not hold") if (a, b) in MAIN else "measured"
        found.append(Finding(
            "scaling_gap", verdict, "psnr", "dB", (a, b),
            {"mean": mean, "se": float(row["PSNR se"]), "flip mean": float(row["FLIP"]),
             "flip se": float(row["FLIP se"])}, TABLE1_BUDGET,
            detail={"data": row["data"], "train_scenes": int(row["train scenes"]), "steps": int(row["steps"]),
                    "rule": row["rule"], "code": row["code"],
                    "seeds": {a: row["a seeds"], b: row["b seeds"]},
                    **({"claim": f"{a} above {b}"} if (a, b) in MAIN else {})}))
    return found

"""The report's findings about the full method F against the other rows (docs/benchmark.md "Reports"), as
:class:`mcd.reporting.finding.Finding` records computed from the tables, whether the claims hold or not:

- F against the best other method of Table 1;
- F at or above every trained baseline of Table 1 at 4 spp;
- the F-OIDN gap at 4 spp, over all test scenes and over the training scenes' test frames (aim: F >= OIDN - 1
  dB on the training scenes);
- F above the noisy input at every budget of the spp sweep;
- F against the best other trained method and OIDN at each budget of the spp sweep.
"""

from __future__ import annotations

import math

import pandas as pd

from mcd.config.methods import (
    BASELINE_VARIANTS,
    BY_EXPERIMENT,
    TABLE1_VARIANTS,
    TRAINED_BASELINES,
    display_name,
)
from mcd.data.buffers import UNIFORM_BUDGETS
from mcd.reporting.finding import Finding
from mcd.reporting.runs import Run
from mcd.reporting.select import pick, scene_mean, train_scenes
from mcd.reporting.tables import TABLE1_BUDGET

#: How far below OIDN F may be on the training scenes' test frames and still meet the aim.
OIDN_AIM_DB = 1.0


def _f_over_seeds(spread: pd.DataFrame | None, budget: float) -> pd.Series | None:
    """Row F's line of the seeds sweep's ``spread`` (:func:`mcd.reporting.seeds.spread`) at ``budget``, where
    more than one seed finished."""
    if spread is None or spread.empty:
        return None
    row = spread[(spread["row"] == "F") & (spread["spp"] == budget)]
    return row.iloc[0] if not row.empty and row.iloc[0]["n"] > 1 else None


def headline(t1: pd.DataFrame) -> list[Finding]:
    """F against the best other method of Table 1 (trained or not: OIDN and the noisy input count; F's own
    variants, such as F_paper, and the diagnostics do not)."""
    ours = t1.set_index("experiment")
    if "F" not in ours.index or pd.isna(ours.loc["F", "PSNR"]):
        return [Finding("headline", "cannot check", "psnr", "dB", (), {}, TABLE1_BUDGET)]
    f = float(ours.loc["F", "PSNR"])
    others = ours.drop(index=[e for e in ours.index if e == "F" or TABLE1_VARIANTS.get(e) == "F"
                              or (e in BY_EXPERIMENT and BY_EXPERIMENT[e].diagnostic)])
    others = others["PSNR"].dropna()
    if others.empty:
        return [Finding("headline", "measured", "psnr", "dB", ("F",), {"F": f}, TABLE1_BUDGET)]
    best = str(others.idxmax())
    return [Finding("headline", "holds" if f > others.max() else "does not hold", "psnr", "dB", ("F", best),
                    {"F": f, best: float(others.max())}, TABLE1_BUDGET,
                    detail={"claim": "F above every other method of Table 1",
                            "names": {best: str(ours.loc[best, "method"])}})]


def baselines(t1: pd.DataFrame, spread: pd.DataFrame | None = None) -> list[Finding]:
    """F against every trained baseline of Table 1 (a U-Net row stood in for by row A counts as the U-Net).

    With the seeds sweep's ``spread`` (:func:`mcd.reporting.seeds.spread`) holding F at Table 1's budget,
    the finding gives F's mean over seeds against the best baseline and whether that baseline's PSNR lies
    within F's range over seeds (the baselines ran one seed)."""
    t = t1.set_index("experiment")
    if "F" not in t.index or pd.isna(t.loc["F", "PSNR"]):
        return []
    f = float(t.loc["F", "PSNR"])
    done = {e: float(t.loc[e, "PSNR"]) for e in t.index
            if e in (*TRAINED_BASELINES, *BASELINE_VARIANTS, "A") and not pd.isna(t.loc[e, "PSNR"])}
    missing = [display_name(e) for e in TRAINED_BASELINES
               if e not in done and not (e == "unet" and "A" in done)]
    if not done:
        return [Finding("f_vs_baselines", "cannot check", "psnr", "dB", ("F",), {"F": f}, TABLE1_BUDGET,
                        detail={"missing": missing})]
    verdict = ("does not hold" if max(done.values()) > f else "holds" if not missing else "holds so far")
    detail: dict[str, object] = {"claim": "F at or above every trained baseline", "missing": missing,
                                 "names": {e: str(t.loc[e, "method"]) for e in done}}
    r = _f_over_seeds(spread, TABLE1_BUDGET)
    if r is not None:
        detail["seeds"] = {"n": int(r["n"]), "mean": float(r["PSNR mean"]), "std": float(r["PSNR std"]),
                           "min": float(r["PSNR min"]), "max": float(r["PSNR max"])}
    return [Finding("f_vs_baselines", verdict, "psnr", "dB", ("F", *done), {"F": f, **done}, TABLE1_BUDGET,
                    detail=detail)]


def oidn_gap(runs: list[Run], budget: float = 4.0, spread: pd.DataFrame | None = None) -> list[Finding]:
    """F - OIDN at ``budget``: over all test scenes, and over the training scenes' test frames against the
    aim of being at most :data:`OIDN_AIM_DB` below OIDN; per scene beside. With the seeds sweep's ``spread``
    holding F at ``budget``, the training-scene gap of F's mean over seeds too (OIDN is deterministic)."""
    f = pick(runs, "F", budget, prefer_sweep="ablation")
    oidn = pick(runs, "oidn", budget, prefer_sweep="baselines")
    if f is None or oidn is None or f.status != "ok" or oidn.status != "ok":
        return []
    found = [Finding("f_minus_oidn", "measured", "psnr", "dB", ("F", "oidn"),
                     {"F": f.metrics["psnr"], "oidn": oidn.metrics["psnr"]}, budget)]
    train = train_scenes(f)
    fp, op = scene_mean(f, train), scene_mean(oidn, train)
    if not math.isnan(fp) and not math.isnan(op):
        per_f, per_o = f.metrics["per_scene"], oidn.metrics["per_scene"]
        per_scene = {s: per_f[s]["psnr"] - per_o[s]["psnr"] for s in per_f if s in per_o}
        aim = {"claim": f"F >= {display_name('oidn')} - {OIDN_AIM_DB:g} dB on the training scenes' test "
                        "frames",
               "aim_db": OIDN_AIM_DB}
        found.append(Finding("f_minus_oidn_train_scenes", "met" if fp - op >= -OIDN_AIM_DB else "not met",
                             "psnr", "dB", ("F", "oidn"), {"F": fp, "oidn": op}, budget, tuple(train),
                             detail={**aim, "per_scene": per_scene}))
        r = _f_over_seeds(spread, budget)
        if r is not None:
            mean = float(r["PSNR train scenes mean"])
            found.append(Finding("f_minus_oidn_over_seeds", "met" if mean - op >= -OIDN_AIM_DB else "not met",
                                 "psnr", "dB", ("F", "oidn"), {"F": mean, "oidn": op}, budget, tuple(train),
                                 detail={**aim, "n": int(r["n"]), "std": float(r["PSNR train scenes std"])}))
    return found


def above_input(spp_df: pd.DataFrame) -> list[Finding]:
    """F against the noisy input at each budget of the spp sweep (both finished)."""
    ok = spp_df[spp_df["status"] == "ok"]
    f = ok[ok["experiment"] == "F"].set_index("budget")["psnr"]
    noisy = ok[ok["experiment"] == "noisy"].set_index("budget")["psnr"]
    budgets = sorted(set(f.index) & set(noisy.index))
    if not budgets:
        return []
    gains = {float(b): float(f[b] - noisy[b]) for b in budgets}
    missing = [float(b) for b in UNIFORM_BUDGETS if b > 1 and b not in gains]  # F's sampling needs 1 < s
    verdict = ("does not hold" if any(g <= 0 for g in gains.values()) else
               "holds" if not missing else "holds so far")
    return [Finding("f_above_input", verdict, "psnr", "dB", ("F", "noisy"),
                    {f"F - noisy at {b:g} spp": g for b, g in gains.items()},
                    detail={"claim": "F above its noisy input at every budget",
                            "gains": {f"{b:g}": g for b, g in gains.items()}, "not_measured": missing})]


def against_budgets(spp_df: pd.DataFrame) -> list[Finding]:
    """F against the best other trained method (the trained baselines and the U-Net's row A) and against OIDN
    at each budget where F and one of them finished: whether F's margin holds as the budget grows."""
    ok = spp_df[spp_df["status"] == "ok"]
    f = ok[ok["experiment"] == "F"].set_index("budget")["psnr"]
    trained = ok[ok["experiment"].isin((*TRAINED_BASELINES, *BASELINE_VARIANTS, "A"))]
    per_best, per_oidn, names = [], [], {}
    for b in sorted(f.index):
        at = trained[trained["budget"] == b]
        if not at.empty:
            best = at.loc[at["psnr"].idxmax()]
            names[str(best["experiment"])] = str(best["method"])
            per_best.append({"budget": float(b), "best": str(best["experiment"]),
                             "gap": float(f[b] - best["psnr"])})
        oidn = ok[(ok["experiment"] == "oidn") & (ok["budget"] == b)]
        if not oidn.empty:
            per_oidn.append({"budget": float(b), "gap": float(f[b] - float(oidn["psnr"].iloc[0]))})
    found = []
    if per_best:
        found.append(Finding("f_vs_best_per_budget", "measured", "psnr", "dB", ("F", *names),
                             {f"F - best at {p['budget']:g} spp": p["gap"] for p in per_best},
                             detail={"per_budget": per_best, "names": names}))
    if per_oidn:
        found.append(Finding("f_minus_oidn_per_budget", "measured", "psnr", "dB", ("F", "oidn"),
                             {f"F - oidn at {p['budget']:g} spp": p["gap"] for p in per_oidn},
                             detail={"per_budget": per_oidn}))
    return found

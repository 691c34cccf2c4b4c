"""The report's findings about the full method F against the other rows (docs/benchmark.md "Reports"), stated
plainly from the tables, whether they hold or not:

- F at or above every trained baseline of Table 1 at 4 spp;
- the F-OIDN gap at 4 spp, over all test scenes and over the training scenes' test frames (aim: F >= OIDN - 1
  dB on the training scenes);
- F above the noisy input at every budget of the spp sweep;
- F against the best other trained method and OIDN at each budget of the spp sweep.
"""

from __future__ import annotations

import math

import pandas as pd

from mcd.data.buffers import UNIFORM_BUDGETS
from mcd.methods import TABLE1_VARIANTS, TRAINED_BASELINES, display_name
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


def baselines(t1: pd.DataFrame, spread: pd.DataFrame | None = None) -> list[str]:
    """F against every trained baseline of Table 1 (a U-Net row stood in for by row A counts as the U-Net).

    With the seeds sweep's ``spread`` (:func:`mcd.reporting.seeds.spread`) holding F at Table 1's budget,
    the line gives F's mean over seeds against the best baseline and says whether that baseline's PSNR lies
    within F's range over seeds (the baselines ran one seed)."""
    t = t1.set_index("experiment")
    if "F" not in t.index or pd.isna(t.loc["F", "PSNR"]):
        return []
    f = float(t.loc["F", "PSNR"])
    done = {e: float(t.loc[e, "PSNR"]) for e in t.index
            if e in (*TRAINED_BASELINES, *TABLE1_VARIANTS, "A") and not pd.isna(t.loc[e, "PSNR"])}
    missing = [display_name(e) for e in TRAINED_BASELINES
               if e not in done and not (e == "unet" and "A" in done)]
    if not done:
        return ["F against the trained baselines at 4 spp: none of them finished."]
    above = sorted(((e, p) for e, p in done.items() if p > f), key=lambda x: -x[1])
    if above:
        verdict = "does NOT hold: " + ", ".join(
            f"{t.loc[e, 'method']} {p:.2f} dB (+{p - f:.2f})" for e, p in above)
    else:
        verdict = "holds" if not missing else "holds against those finished so far"
    rest = f" ({', '.join(missing)} not finished)" if missing else ""
    best = max(done.values())
    seeds = ""
    r = _f_over_seeds(spread, TABLE1_BUDGET)
    if r is not None:
        where = ("above F's whole range" if best > r["PSNR max"] else
                 "below F's whole range" if best < r["PSNR min"] else "within F's range")
        seeds = (f" Over {int(r['n'])} seeds F's PSNR has a mean of {r['PSNR mean']:.2f} dB "
                 f"({r['PSNR mean'] - best:+.2f} against the best baseline) and a standard deviation of "
                 f"{r['PSNR std']:.2f} dB (range {r['PSNR min']:.2f}-{r['PSNR max']:.2f}); the best "
                 f"baseline's {best:.2f} dB lies {where}; each baseline ran one seed.")
    return [f"F at or above every trained baseline at 4 spp: {verdict}; F {f:.2f} dB, {f - best:+.2f} dB "
            f"against the best of them{rest}.{seeds}"]


def oidn_gap(runs: list[Run], budget: float = 4.0, spread: pd.DataFrame | None = None) -> list[str]:
    """F - OIDN at ``budget``: over all test scenes, and over the training scenes' test frames against the
    aim of being at most :data:`OIDN_AIM_DB` below OIDN; per scene beside. With the seeds sweep's ``spread``
    holding F at ``budget``, the training-scene gap of F's mean over seeds too (OIDN is deterministic)."""
    f = pick(runs, "F", budget, prefer_sweep="ablation")
    oidn = pick(runs, "oidn", budget, prefer_sweep="baselines")
    if f is None or oidn is None or f.status != "ok" or oidn.status != "ok":
        return []
    lines = [f"F - OIDN at {budget:g} spp over all test scenes: "
             f"{f.metrics['psnr'] - oidn.metrics['psnr']:+.2f} dB (F {f.metrics['psnr']:.2f}, "
             f"OIDN {oidn.metrics['psnr']:.2f})."]
    train = train_scenes(f)
    fp, op = scene_mean(f, train), scene_mean(oidn, train)
    if not math.isnan(fp) and not math.isnan(op):
        gap = fp - op
        verdict = "met" if gap >= -OIDN_AIM_DB else "NOT met"
        per_f, per_o = f.metrics["per_scene"], oidn.metrics["per_scene"]
        scenes = ", ".join(f"{s} {per_f[s]['psnr'] - per_o[s]['psnr']:+.2f}" for s in per_f if s in per_o)
        lines.append(f"F - OIDN on the training scenes' test frames: {gap:+.2f} dB (F {fp:.2f}, "
                     f"OIDN {op:.2f}); the aim F >= OIDN - {OIDN_AIM_DB:g} dB is {verdict}. "
                     f"Per test scene (the held-out ones too): {scenes}.")
        r = _f_over_seeds(spread, budget)
        if r is not None:
            mean = r["PSNR train scenes mean"]
            verdict = "met" if mean - op >= -OIDN_AIM_DB else "NOT met"
            lines.append(f"Over {int(r['n'])} seeds of F: {mean - op:+.2f} dB on the training scenes' "
                         f"test frames (F's mean {mean:.2f}, standard deviation "
                         f"{r['PSNR train scenes std']:.2f} dB); the aim is {verdict} by the mean.")
    return lines


def above_input(spp_df: pd.DataFrame) -> list[str]:
    """F against the noisy input at each budget of the spp sweep (both finished)."""
    ok = spp_df[spp_df["status"] == "ok"]
    f = ok[ok["experiment"] == "F"].set_index("budget")["psnr"]
    noisy = ok[ok["experiment"] == "noisy"].set_index("budget")["psnr"]
    budgets = sorted(set(f.index) & set(noisy.index))
    if not budgets:
        return []
    gains = {b: float(f[b] - noisy[b]) for b in budgets}
    below = [f"{b:g} spp ({g:+.2f} dB)" for b, g in gains.items() if g <= 0]
    missing = [f"{b:g}" for b in UNIFORM_BUDGETS if b > 1 and b not in gains]  # F's sampling needs 1 < s
    if below:
        verdict = "does NOT hold at " + ", ".join(below)
    else:
        verdict = "holds" if not missing else "holds at every budget measured so far"
    if missing:
        verdict += f" (not measured yet: {', '.join(missing)} spp)"
    each = ", ".join(f"{b:g} spp {g:+.2f}" for b, g in gains.items())
    return [f"F above its noisy input at every budget: {verdict}. F - noisy per budget: {each} dB."]


def against_budgets(spp_df: pd.DataFrame) -> list[str]:
    """F against the best other trained method (the trained baselines and the U-Net's row A) and against OIDN
    at each budget where F and one of them finished: whether F's margin holds as the budget grows."""
    ok = spp_df[spp_df["status"] == "ok"]
    f = ok[ok["experiment"] == "F"].set_index("budget")["psnr"]
    trained = ok[ok["experiment"].isin((*TRAINED_BASELINES, *TABLE1_VARIANTS, "A"))]
    parts, oidn_parts = [], []
    for b in sorted(f.index):
        at = trained[trained["budget"] == b]
        if not at.empty:
            best = at.loc[at["psnr"].idxmax()]
            parts.append(f"{b:g} spp {f[b] - best['psnr']:+.2f} ({best['method']})")
        oidn = ok[(ok["experiment"] == "oidn") & (ok["budget"] == b)]
        if not oidn.empty:
            oidn_parts.append(f"{b:g} spp {f[b] - float(oidn['psnr'].iloc[0]):+.2f}")
    lines = []
    if parts:
        lines.append(f"F - the best other trained method per budget (one seed each): {', '.join(parts)} dB.")
    if oidn_parts:
        lines.append("F - OIDN per budget: " + ", ".join(oidn_parts) + " dB.")
    return lines

"""Run-to-run spread (``sweeps/seeds.yaml``): each row of the component chain trained from several seeds.

One seed per job cannot tell a real gain from noise at a small training budget. This table gives, per row
and budget, the mean, sample standard deviation and range of PSNR and SSIM over seeds, and the differences
the paper's claims rest on (docs/benchmark.md "What it must show": F above A, C's step over B the largest)
with their standard errors. Differences are of means, not paired by seed: rows draw crops and initial weights
from one generator in different orders, so the same seed value gives two rows nothing in common.
"""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd

from mcd.reporting.finding import Finding, render
from mcd.reporting.outputs import writes
from mcd.reporting.runs import Run
from mcd.reporting.select import metric, to_markdown, train_scene_metric, write_table
from mcd.reporting.tables import STEPS

SEEDS_SWEEP = "seeds"

#: What it writes in a report's folder (mcd.reporting.outputs).
MD, CSV, DIFFERENCES = writes("standard", "seeds.md", "seeds.csv", "seeds_differences.csv")


def seed_runs(runs: list[Run]) -> list[Run]:
    """Finished, non-transfer jobs of the seeds sweep that know their seed and budget, and the ablation
    sweep's seed-0 jobs of the same experiments, profile and budget where the seeds sweep has no seed 0: the
    same job (a seeds sweep run with ``seed=1,2,3,4`` reuses them instead of training seed 0 again)."""
    ok = [r for r in runs if r.status == "ok" and r.transfer is None and r.seed is not None
          and r.budget is not None]
    seeds = [r for r in ok if r.sweep == SEEDS_SWEEP]
    have_zero = {(r.experiment, r.budget, r.data_profile) for r in seeds if r.seed == 0}
    wanted = {(r.experiment, r.budget, r.data_profile) for r in seeds}
    zeros = [r for r in ok if r.sweep == "ablation" and r.seed == 0
             and (key := (r.experiment, r.budget, r.data_profile)) in wanted and key not in have_zero]
    return seeds + zeros


def _by_seed(runs: list[Run]) -> dict[tuple[str, float], dict[int, tuple[float, float, float]]]:
    """(experiment, budget) -> seed -> (PSNR, SSIM, PSNR over the training scenes' test frames; NaN if
    absent); the first run by path wins a duplicated seed."""
    out: dict[tuple[str, float], dict[int, tuple[float, float, float]]] = {}
    for r in sorted(runs, key=lambda r: str(r.path)):
        per_seed = out.setdefault((r.experiment, r.budget), {})
        per_seed.setdefault(r.seed, (metric(r, "psnr"), metric(r, "ssim"), train_scene_metric(r)))
    return out


def _std(values: list[float]) -> float:
    """Sample standard deviation (n-1); NaN below two values."""
    return float(pd.Series(values).std(ddof=1)) if len(values) > 1 else math.nan


def spread(runs: list[Run]) -> pd.DataFrame:
    """One row per (experiment, budget): seeds, PSNR and SSIM x1e2 mean / std / min / max, and PSNR over the
    training scenes' test frames (the paper's protocol; the all-scene mean includes held-out scenes, which
    move most between runs) mean / std."""
    rows = []
    for (exp, budget), per_seed in sorted(_by_seed(seed_runs(runs)).items()):
        psnr = [v[0] for v in per_seed.values()]
        ssim = [v[1] * 1e2 for v in per_seed.values()]
        train = [v[2] for v in per_seed.values()]
        rows.append(
            {
                "row": exp,
                "spp": int(budget),
                "seeds": " ".join(str(s) for s in sorted(per_seed)),
                "n": len(per_seed),
                "PSNR mean": sum(psnr) / len(psnr),
                "PSNR std": _std(psnr),
                "PSNR min": min(psnr),
                "PSNR max": max(psnr),
                "SSIM mean": sum(ssim) / len(ssim),
                "SSIM std": _std(ssim),
                "PSNR train scenes mean": sum(train) / len(train),
                "PSNR train scenes std": _std(train),
            }
        )
    return pd.DataFrame(rows)


#: What each row of the chain adds to the row before it (docs/method.md "Component study").
ADDS = {"B": "AS", "C": "KP", "D": "PP", "E": "FG", "F": "SA"}


def _chain_pairs(experiments: set[str]) -> list[tuple[str, str]]:
    """Consecutive rows of the chain A→...→F among those that ran, and F-A when both ran."""
    present = [e for e in STEPS if e in experiments]
    pairs = list(zip(present, present[1:], strict=False))
    if "A" in experiments and "F" in experiments and ("A", "F") not in pairs:
        pairs.append(("A", "F"))
    return pairs


def _mean_difference(pa: list[float], pb: list[float]) -> tuple[float, float]:
    """Mean of ``pb`` minus mean of ``pa`` and its standard error, ``sqrt(s_a^2/n_a + s_b^2/n_b)``."""
    se = math.sqrt(_std(pa) ** 2 / len(pa) + _std(pb) ** 2 / len(pb))
    return sum(pb) / len(pb) - sum(pa) / len(pa), se


def differences(runs: list[Run]) -> pd.DataFrame:
    """Mean PSNR of `b` minus mean PSNR of `a` over their seeds, for consecutive chain rows and F - A, with
    the standard error of that difference and whether the two rows' seed ranges overlap; the same difference
    over the training scenes' test frames beside it (`train`)."""
    by = _by_seed(seed_runs(runs))
    rows = []
    for budget in sorted({b for _, b in by}):
        for a, b in _chain_pairs({e for e, bb in by if bb == budget}):
            pa = [v[0] for v in by[(a, budget)].values()]
            pb = [v[0] for v in by[(b, budget)].values()]
            diff, se = _mean_difference(pa, pb)
            train_diff, train_se = _mean_difference([v[2] for v in by[(a, budget)].values()],
                                                    [v[2] for v in by[(b, budget)].values()])
            rows.append(
                {
                    "difference": f"{b} - {a}",
                    "adds": "+".join(ADDS[x] for x in STEPS[STEPS.index(a) + 1 : STEPS.index(b) + 1]),
                    "spp": int(budget),
                    "n": f"{len(pb)}/{len(pa)}",
                    "mean dB": diff,
                    "se dB": se,
                    "mean/se": diff / se if se > 0 else math.nan,
                    "ranges": "separate" if min(pb) > max(pa) or max(pb) < min(pa) else "overlap",
                    "train mean dB": train_diff,
                    "train se dB": train_se,
                }
            )
    return pd.DataFrame(rows)


def _train(row: pd.Series) -> dict[str, float]:
    """The training scenes' mean difference and its standard error of a row of :func:`differences` (NaN when
    the runs have no per-scene scores)."""
    if "train mean dB" not in row or pd.isna(row["train mean dB"]):
        return {"train mean": math.nan, "train se": math.nan}
    return {"train mean": float(row["train mean dB"]), "train se": float(row["train se dB"])}


def checks(diffs: pd.DataFrame) -> list[Finding]:
    """The paper's two claims restated over seeds, each with its standard error: F above A, and B→C the
    largest single-component step (differences spanning several components, e.g. F - C, are listed but not
    ranked against single steps)."""
    found: list[Finding] = []
    if diffs.empty:
        return found
    for budget, df in diffs.groupby("spp"):
        rows = df.set_index("difference")
        if "F - A" in rows.index:
            r = rows.loc["F - A"]
            found.append(Finding("seeds_f_above_a", "holds" if r["mean dB"] > 0 else "does not hold", "psnr",
                                 "dB", ("F", "A"), {"mean": float(r["mean dB"]), "se": float(r["se dB"]),
                                                    **_train(r)}, float(budget),
                                 detail={"claim": "F above A on average over seeds", "n": str(r["n"])}))
        steps = df[df["difference"] != "F - A"]
        single = steps[~steps["adds"].str.contains("+", regex=False)]
        if "C - B" in rows.index:
            r = rows.loc["C - B"]
            largest = str(single.loc[single["mean dB"].idxmax(), "difference"])
            top = (str(single.loc[single["train mean dB"].idxmax(), "difference"])
                   if "train mean dB" in single and single["train mean dB"].notna().all() else None)
            listed = [{"difference": d, "adds": a, "mean": float(m), "se": float(e)}
                      for d, a, m, e in zip(steps["difference"], steps["adds"], steps["mean dB"],
                                            steps["se dB"], strict=True)]
            verdict = "holds" if largest == "C - B" else "does not hold"
            values = {"mean": float(r["mean dB"]), "se": float(r["se dB"]), **_train(r)}
            found.append(Finding("seeds_kp_largest_step", verdict, "psnr", "dB", ("C", "B"), values,
                                 float(budget),
                                 detail={"claim": "C - B the largest single-component step over seeds",
                                         "largest": largest, "largest_train": top, "steps": listed,
                                         "single_steps": len(single)}))
    return found


def _job_key(run: Run) -> tuple[object, ...]:
    """Two jobs are the same job when experiment, budget, seed (default 0), profile and steps agree."""
    steps = run.metrics.get("train_steps") if run.metrics is not None else None
    return (run.experiment, run.budget, run.seed or 0, run.data_profile, steps)


def reproducibility(runs: list[Run]) -> list[Finding]:
    """Seeds-sweep jobs that repeat another sweep's job (same :func:`_job_key`): how far apart their PSNRs
    are. Same code and config should give the same number."""
    others: dict[tuple[object, ...], list[Run]] = {}
    for o in runs:
        if o.sweep != SEEDS_SWEEP and o.status == "ok" and o.transfer is None:
            others.setdefault(_job_key(o), []).append(o)
    gaps = [
        (abs(metric(r, "psnr") - metric(o, "psnr")), r.experiment)
        for r in seed_runs(runs)
        for o in others.get(_job_key(r), [])
        if o.path != r.path  # an ablation seed-0 job standing in for the seeds sweep is not its own repeat
    ]
    if not gaps:
        return []
    return [Finding("repeatability", "measured", "psnr", "dB", tuple(sorted({e for _, e in gaps})),
                    {"jobs": float(len(gaps)), "largest difference": max(gaps)[0]})]


def write(runs: list[Run], out_dir: Path) -> dict[str, pd.DataFrame]:
    """`seeds.md/.csv` (spread per row) and `seeds_differences.csv` when the seeds sweep ran; {} otherwise."""
    table = spread(runs)
    if table.empty:
        return {}
    diffs = differences(runs)
    notes = [
        "SSIM x1e2; std: sample standard deviation over seeds (n-1). A seed sets the weights' "
        "initialisation, the training crops and the sample order (run.py seeds everything).",
        *map(render, [*checks(diffs), *reproducibility(runs)]),
    ]
    write_table(table, out_dir, "seeds", "Run-to-run spread over seeds", notes)
    if not diffs.empty:
        diffs.to_csv(out_dir / DIFFERENCES, index=False)
        with (out_dir / MD).open("a") as md:
            md.write("\n## Differences of mean PSNR between rows (dB)\n\n")
            md.write(
                "`se`: standard error of the difference, sqrt(s_a^2/n_a + s_b^2/n_b); `ranges`: whether "
                "the two rows' PSNR over seeds overlap; `train mean`, `train se`: the same difference over "
                "the training scenes' test frames (the paper's protocol).\n\n" + to_markdown(diffs)
            )
    return {"seeds": table, "seeds_differences": diffs}

"""A report's findings as data (docs/benchmark.md "Reports"): each finding is one :class:`Finding` record
(what kind of check, the claim's verdict, the metric, the methods compared, their values, budget and scenes),
written to ``findings.json`` beside the report's README; the README's prose is :func:`render` of each record,
so that a reader of the JSON and a reader of the README see the same facts.

The generators live beside the tables they read (``mcd.reporting.findings``, ``tables.component_checks``,
``seeds.checks``); this module holds the record, its JSON form and the one renderer per ``kind``.

Contract: a finding never compares a method with itself. ``subjects`` are distinct experiments (the record
refuses duplicates), and a comparison's two sides are different subjects.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from mcd.config.methods import display_name
from mcd.reporting.outputs import writes

#: The findings as data, in every report kind's folder (mcd.reporting.outputs).
FILE, = writes("both", "findings.json")

#: A difference this many standard errors from zero is called resolved by the seeds.
RESOLVED_SE = 2.0


@dataclass(frozen=True)
class Finding:
    """One finding.

    - ``kind``: which check (a key of :data:`RENDERERS`);
    - ``verdict``: ``holds``, ``does not hold``, ``holds so far`` (some of its rows have not run), ``met`` /
      ``not met`` (an aim), ``cannot check`` (rows missing), or ``measured`` (a quantity, no claim);
    - ``metric`` and ``unit``: what the values measure (``psnr`` in ``dB``, ...);
    - ``subjects``: the experiments the finding is about, the claim's subject first, each once;
    - ``values``: named numbers (an experiment's value under its name, differences as ``<a> - <b>``);
    - ``budget``: samples per pixel (None: several, see ``detail``); ``scenes``: the test scenes it covers
      (empty: every test scene); ``source``: ``ours`` or ``paper`` (the paper's own numbers);
    - ``detail``: whatever else the sentence states (per-budget and per-scene values, rows not run).
    """

    kind: str
    verdict: str
    metric: str
    unit: str
    subjects: tuple[str, ...]
    values: dict[str, float]
    budget: float | None = None
    scenes: tuple[str, ...] = ()
    source: str = "ours"
    detail: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.kind not in RENDERERS:
            raise ValueError(f"finding kind {self.kind!r} has no renderer (mcd.reporting.finding.RENDERERS)")
        if len(set(self.subjects)) != len(self.subjects):
            raise ValueError(f"finding {self.kind!r} names a method twice ({list(self.subjects)}): a finding "
                             "never compares a method with itself")

    def record(self) -> dict[str, Any]:
        """The JSON form: NaN becomes null."""
        return _clean(asdict(self))

    @classmethod
    def from_record(cls, rec: dict[str, Any]) -> Finding:
        """The finding of one ``findings.json`` entry (null values read back as NaN)."""
        rec = dict(rec)
        rec["subjects"] = tuple(rec["subjects"])
        rec["scenes"] = tuple(rec.get("scenes", ()))
        rec["values"] = {k: math.nan if v is None else float(v) for k, v in rec["values"].items()}
        return cls(**rec)


def _clean(value: Any) -> Any:
    if isinstance(value, float):
        return None if math.isnan(value) else value
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    return value


def write(findings: list[Finding], out_dir: Path) -> Path:
    """``findings.json``: ``{"findings": [record, ...]}``, each record with its rendering as ``text``."""
    path = out_dir / FILE
    records = [{**f.record(), "text": render(f)} for f in findings]
    path.write_text(json.dumps({"findings": records}, indent=1, allow_nan=False) + "\n")
    return path


def read(path: Path) -> list[Finding]:
    """The findings of a ``findings.json``."""
    data = json.loads(path.read_text())
    return [Finding.from_record({k: v for k, v in r.items() if k != "text"}) for r in data["findings"]]


def _name(f: Finding, exp: str) -> str:
    return f.detail.get("names", {}).get(exp) or display_name(exp)


def _verdict(v: str) -> str:
    """The verdict as the prose says it (a negative one in capitals, so that it is not read past)."""
    return {"does not hold": "does NOT hold", "not met": "NOT met", "holds so far": "holds"}.get(v, v)


# --- renderers, one per kind: each reads only its record ---------------------------------------------------

def _headline(f: Finding) -> str:
    if f.verdict == "cannot check":
        return "No finished run of F at 4 spp: the full method's standing cannot be stated."
    if len(f.subjects) == 1:
        return f"F: {f.values['F']:.2f} dB; no other method finished to compare with."
    other = f.subjects[1]
    gap = f.values["F"] - f.values[other]
    return (f"F is {abs(gap):.2f} dB {'above' if gap > 0 else 'below'} the best other method here "
            f"({_name(f, other)}, {f.values[other]:.2f} dB); F {f.values['F']:.2f} dB.")


def _baselines(f: Finding) -> str:
    if f.verdict == "cannot check":
        return "F at or above every trained baseline at 4 spp: none of them finished."
    fv = f.values["F"]
    others = {e: f.values[e] for e in f.subjects[1:]}
    above = sorted(((e, p) for e, p in others.items() if p > fv), key=lambda x: -x[1])
    missing = f.detail.get("missing", [])
    if above:
        verdict = "does NOT hold: " + ", ".join(f"{_name(f, e)} {p:.2f} dB (+{p - fv:.2f})" for e, p in above)
    else:
        verdict = "holds" if not missing else "holds against those finished so far"
    rest = f" ({', '.join(missing)} not finished)" if missing else ""
    best = max(others.values())
    seeds = ""
    s = f.detail.get("seeds")
    if s:
        where = ("above F's whole range" if best > s["max"] else
                 "below F's whole range" if best < s["min"] else "within F's range")
        seeds = (f" Over {s['n']} seeds F's PSNR has a mean of {s['mean']:.2f} dB "
                 f"({s['mean'] - best:+.2f} against the best baseline) and a standard deviation of "
                 f"{s['std']:.2f} dB (range {s['min']:.2f}-{s['max']:.2f}); the best "
                 f"baseline's {best:.2f} dB lies {where}; each baseline ran one seed.")
    return (f"F at or above every trained baseline at 4 spp: {verdict}; F {fv:.2f} dB, {fv - best:+.2f} dB "
            f"against the best of them{rest}.{seeds}")


def _oidn_all(f: Finding) -> str:
    oidn = _name(f, "oidn")
    return (f"F - {oidn} at {f.budget:g} spp over all test scenes: "
            f"{f.values['F'] - f.values['oidn']:+.2f} dB (F {f.values['F']:.2f}, {oidn} "
            f"{f.values['oidn']:.2f}).")


def _oidn_train(f: Finding) -> str:
    scenes = ", ".join(f"{s} {g:+.2f}" for s, g in f.detail["per_scene"].items())
    oidn = _name(f, "oidn")
    return (f"F - {oidn} on the training scenes' test frames: {f.values['F'] - f.values['oidn']:+.2f} dB "
            f"(F {f.values['F']:.2f}, {oidn} {f.values['oidn']:.2f}); the aim F >= {oidn} - "
            f"{f.detail['aim_db']:g} dB is {_verdict(f.verdict)}. Per test scene (the held-out ones too): "
            f"{scenes}.")


def _oidn_seeds(f: Finding) -> str:
    gap = f.values["F"] - f.values["oidn"]
    return (f"Over {f.detail['n']} seeds of F: {gap:+.2f} dB on the training scenes' test frames (F's mean "
            f"{f.values['F']:.2f}, standard deviation {f.detail['std']:.2f} dB); the aim is "
            f"{_verdict(f.verdict)} by the mean.")


def _above_input(f: Finding) -> str:
    gains = {float(b): g for b, g in f.detail["gains"].items()}
    below = [f"{b:g} spp ({g:+.2f} dB)" for b, g in gains.items() if g <= 0]
    missing = f.detail.get("not_measured", [])
    if below:
        verdict = "does NOT hold at " + ", ".join(below)
    else:
        verdict = "holds" if not missing else "holds at every budget measured so far"
    if missing:
        verdict += f" (not measured yet: {', '.join(f'{b:g}' for b in missing)} spp)"
    each = ", ".join(f"{b:g} spp {g:+.2f}" for b, g in gains.items())
    return f"F above its noisy input at every budget: {verdict}. F - noisy per budget: {each} dB."


def _best_per_budget(f: Finding) -> str:
    parts = ", ".join(f"{p['budget']:g} spp {p['gap']:+.2f} ({_name(f, p['best'])})"
                      for p in f.detail["per_budget"])
    return f"F - the best other trained method per budget (one seed each): {parts} dB."


def _oidn_per_budget(f: Finding) -> str:
    parts = ", ".join(f"{p['budget']:g} spp {p['gap']:+.2f}" for p in f.detail["per_budget"])
    return f"F - {_name(f, 'oidn')} per budget: {parts} dB."


def _who(f: Finding) -> str:
    return "ours" if f.source == "ours" else "the paper's numbers"


def _rows_missing(f: Finding) -> str:
    return (f"Component study ({_who(f)}): cannot check the step claims, rows "
            f"{', '.join(f.detail['missing'])} have no PSNR.")


def _f_above_a(f: Finding) -> str:
    gap = f.values["F"] - f.values["A"]
    return (f"Component study ({_who(f)}): F above A {_verdict(f.verdict)} (F {f.values['F']:.2f} dB vs "
            f"A {f.values['A']:.2f} dB, {gap:+.2f} dB).")


def _kp_step(f: Finding) -> str:
    steps = f.detail["steps"]
    largest = max(steps, key=steps.get)
    why = "" if f.verdict == "holds" else f" (largest step is {largest})"
    listed = ", ".join(f"{name} {gain:+.2f} dB" for name, gain in steps.items())
    return (f"Component study ({_who(f)}): C's gain over B is the largest single step: "
            f"{_verdict(f.verdict)}{why}. Steps: {listed}.")


def _kp_identity(f: Finding) -> str:
    lo, hi = f.subjects[0], f.subjects[-1]
    note = (" (near 1: i_bar == i, the kernel pool is bypassed and KP adds only its heads' capacity)"
            if f.values[lo] > 0.95 else "")
    share = (f"{f.values[lo]:.3f} ({lo}) to {f.values[hi]:.3f} ({hi})" if lo != hi
             else f"{f.values[lo]:.3f} ({lo}, the only row with a kernel pool)")
    return (f"Component study (ours): the kernel map's identity share, mean of (h[1]+1)/2 over test pixels, "
            f"is {share}{note}.")


def _kp_spread(f: Finding) -> str:
    lo, hi = f.subjects[0], f.subjects[-1]
    spread = (f"{f.values[lo]:.3f} ({lo}) to {f.values[hi]:.3f} ({hi})" if lo != hi
              else f"{f.values[lo]:.3f} ({lo}, the only row with a kernel pool)")
    return ("Component study (ours): the kernel index h[0] varies across each test frame with a standard "
            f"deviation of {spread} (0 = one kernel everywhere; h[0] spans [-1, 1] over the pool's kernels).")


def resolved(mean: float, se: float) -> str:
    """How many standard errors a difference lies from zero, and whether that resolves it."""
    if math.isnan(se) or se == 0:
        return "spread unknown"
    k = abs(mean) / se
    verdict = "resolved" if k >= RESOLVED_SE else "NOT resolved"
    return f"{k:.1f} standard errors from zero: {verdict} by these seeds"


def _train_note(f: Finding) -> str:
    if math.isnan(f.values.get("train mean", math.nan)):
        return ""
    return (f" On the training scenes' test frames (the paper's protocol): {f.values['train mean']:+.2f} ± "
            f"{f.values['train se']:.2f} dB.")


def _seeds_f_a(f: Finding) -> str:
    m, se = f.values["mean"], f.values["se"]
    return (f"Over seeds, {f.budget:g} spp: F - A = {m:+.2f} ± {se:.2f} dB (mean ± standard error, seeds "
            f"{f.detail['n']}), {resolved(m, se)}; F above A {_verdict(f.verdict)} on average."
            f"{_train_note(f)}")


def _seeds_kp(f: Finding) -> str:
    m, se = f.values["mean"], f.values["se"]
    largest = f.detail["largest"]
    verdict = "is" if f.verdict == "holds" else f"is NOT (largest: {largest})"
    listed = ", ".join(f"{s['difference']} ({s['adds']}) {s['mean']:+.2f} ± {s['se']:.2f}"
                       for s in f.detail["steps"])
    note = _train_note(f)
    top = f.detail.get("largest_train")
    if note and top:
        note += (" It is the largest step there." if top == "C - B"
                 else f" It is NOT the largest step there (largest: {top}).")
    return (f"Over seeds, {f.budget:g} spp: C - B (KP) = {m:+.2f} ± {se:.2f} dB, {resolved(m, se)}; it "
            f"{verdict} the largest of the {f.detail['single_steps']} single-component steps measured. All "
            f"measured steps: {listed} dB.{note}")


def _repeatability(f: Finding) -> str:
    return (f"Repeatability: {int(f.values['jobs'])} seeds-sweep job(s) ({', '.join(f.subjects)}) repeat a "
            f"job of another sweep (same experiment, budget, seed, profile, steps); largest PSNR difference "
            f"{f.values['largest difference']:.4f} dB.")


def _map_health(f: Finding) -> str:
    d, (exp,) = f.detail, f.subjects
    flag = {"collapsed": f"COLLAPSED (spread below {d['collapsed below']:g}: it samples uniformly)",
            "edge-bound": f"EDGE-BOUND (ring share above {d['edge-bound above']:g})",
            "adaptive": "adaptive", "unknown": "unknown (no samples)"}[d["health"]]
    budget = "" if f.budget is None else f", {f.budget:g} spp"
    return (f"Sampling map of {_name(f, exp)} (seed {d['seed']}, {d['data_profile']}{budget}, {d['run']}): "
            f"{flag}; spread (std over mean, mean over test frames) {f.values['spread']:.3g}, the outer "
            f"{d['ring']}-pixel ring's share of the samples {f.values['ring share']:.2f}x its share of the "
            "pixels.")


# --- the scaling study (mcd.reporting.scaling) ------------------------------------------------------------

def _pm(mean: float, se: float, digits: int = 2) -> str:
    """``mean ± se`` (``mean`` alone where the standard error is unknown)."""
    return f"{mean:+.{digits}f}" + ("" if math.isnan(se) else f" ± {se:.{digits}f}")


def _scaling_gap(f: Finding) -> str:
    a, b = f.subjects
    d = f.detail
    m, se = f.values["mean"], f.values["se"]
    res = "" if math.isnan(se) else f", {resolved(m, se)}"
    claim = f"; {_name(f, a)} above {_name(f, b)} {_verdict(f.verdict)}" if "claim" in d else ""
    flip = ("" if math.isnan(f.values["flip mean"])
            else f"; FLIP {_pm(f.values['flip mean'], f.values['flip se'], 4)} (lower is better)")
    return (f"{d['data']}, {d['steps']} steps: {_name(f, a)} - {_name(f, b)} = {_pm(m, se)} dB PSNR "
            f"({d['rule']}; seeds {d['seeds'][a]} / {d['seeds'][b]}){res}{flip}{claim}.")


def _scaling_fit(f: Finding) -> str:
    (exp,) = f.subjects
    budgets = f.detail["budgets"]
    exact = " (two budgets: the line passes through both, so it checks nothing)" if len(budgets) == 2 else ""
    return (f"Fit, {f.detail['data']}, {_name(f, exp)}: PSNR = {f.values['a']:.2f} {f.values['b']:+.2f} x "
            f"log10(steps) dB over the budgets {', '.join(map(str, budgets))}; RMS residual "
            f"{f.values['rms']:.2f} dB{exact}.")


def _scaling_crossing(f: Finding) -> str:
    a, b = f.subjects
    d, v = f.detail, f.values
    name_a, name_b = _name(f, a), _name(f, b)
    largest, steps, per = v["largest budget"], v["crossing steps"], v["per decade"]
    behind = ", ".join(map(str, d["behind"]))
    rate = "" if math.isnan(per) else f"; {name_a} gains {per:+.2f} dB per tenfold steps against {name_b}"
    horizon = f"{d['horizon']:g}x the largest budget ({largest:g} steps)"
    text = {
        "ahead": f"already ahead at every budget (up to {largest:g} steps)",
        "crossed": f"the fits cross at {steps:.3g} steps, within the budgets run ({name_a} not above at "
                   f"{behind} steps)",
        "crosses": f"the fits cross at {steps:.3g} steps, {steps / largest:.1f}x the largest budget "
                   f"({largest:g}): an extrapolation",
        "no crossing": f"no crossing within {horizon}" + (f" (the fits cross at {steps:.3g} steps)"
                                                          if not math.isnan(steps) else
                                                          " (the gap does not close)"),
        "losing": f"{name_a} is above at the largest budget by the fits, but {name_b} gains more per tenfold "
                  f"steps (not above at {behind} steps)",
        "cannot fit": f"cannot fit: one of them ran fewer than two budgets ({name_a} not above at {behind} "
                      "steps)",
        "cannot check": "no budget with both",
    }[d["outcome"]]
    return f"Where {name_a} meets {name_b}, {d['data']}: {text}{rate}."


def _scaling_coverage(f: Finding) -> str:
    v, d = f.values, f.detail
    cells = "; ".join(f"{c['data']} {c['steps']} steps ({', '.join(_name(f, e) for e in c['experiments'])})"
                      for c in d["cells"]) or "none"
    by_point: dict[str, list[str]] = {}
    for m in d["missing"]:
        by_point.setdefault(f"{m['data']} {m['steps']} steps", []).append(
            f"{_name(f, m['experiment'])} (seed{'s' if len(m['seeds']) > 1 else ''} "
            f"{','.join(map(str, m['seeds']))}: {m['status']})")
    missing = "; ".join(f"{k}: {', '.join(e)}" for k, e in by_point.items()) or "none"
    outside = int(v["outside the plan"])
    beyond = f"; {outside} finished run(s) lie outside the plan" if outside else ""
    return (f"The sweep's plan ({d['sweep_file']}) has {int(v['planned'])} jobs: {int(v['finished'])} "
            f"finished, {int(v['failed'])} failed, {int(v['incomplete'])} incomplete, "
            f"{int(v['not run'])} not run{beyond}. Scale points with runs: {cells}. Missing: {missing}.")


RENDERERS: dict[str, Callable[[Finding], str]] = {
    "headline": _headline,
    "f_vs_baselines": _baselines,
    "f_minus_oidn": _oidn_all,
    "f_minus_oidn_train_scenes": _oidn_train,
    "f_minus_oidn_over_seeds": _oidn_seeds,
    "f_above_input": _above_input,
    "f_vs_best_per_budget": _best_per_budget,
    "f_minus_oidn_per_budget": _oidn_per_budget,
    "component_rows_missing": _rows_missing,
    "f_above_a": _f_above_a,
    "kp_largest_step": _kp_step,
    "kp_identity_share": _kp_identity,
    "kp_index_spread": _kp_spread,
    "seeds_f_above_a": _seeds_f_a,
    "seeds_kp_largest_step": _seeds_kp,
    "repeatability": _repeatability,
    "sampling_map_health": _map_health,
    "scaling_gap": _scaling_gap,
    "scaling_fit": _scaling_fit,
    "scaling_crossing": _scaling_crossing,
    "scaling_coverage": _scaling_coverage,
}


def render(f: Finding) -> str:
    """The sentence a report prints for ``f``, from the record alone."""
    return RENDERERS[f.kind](f)

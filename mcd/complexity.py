"""``python -m mcd.complexity``: params and 1920x1080 MACs of every registered experiment beside the
paper's (docs/benchmark.md "Metrics").

``python -m mcd.complexity [--capacity paper] [--experiments A B ...] [-o PATH]`` prints the table; with
``-o`` it also writes it as CSV (``name, params_m, gmacs_1080p, paper_params_m, paper_gmacs``; NaN, and an
"unavailable" note in the printed table, for a method whose optional package is missing). It writes nothing
else: the tracked ``reports/complexity.csv`` changes only when asked for by name. Experiments are
:func:`mcd.config.compose.experiment_names` (rows A-M from the component table, then
``conf/experiment/*.yaml``), so a new method only needs its config (and its paper numbers in
:mod:`mcd.config.methods`). The counting itself is :mod:`mcd.models.complexity`.

Below the table it prints the shares (``--shares cpu``, the default; ``--shares none`` skips them): each
trained Table 1 method's MACs in that profile over its MACs in the ``paper`` profile, both counted from the
built models, and each share's ratio to F's. The ``cpu`` profile keeps every ratio within
:data:`SHARE_BAND` of 1 (Table 1 compares designs, not budgets; docs/training.md "Capacity
profiles"). ``--shares-out PATH`` also writes them as CSV (``name, gmacs_1080p, paper_profile_gmacs_1080p,
share, ratio_to_F``).
"""

from __future__ import annotations

import argparse
import csv
import functools
import math
from pathlib import Path

from omegaconf import DictConfig

from mcd.config.compose import compose, experiment_names
from mcd.config.methods import CATALOGUE, paper_complexity
from mcd.core.config_rules import MAX_SIDE
from mcd.core.paths import CONF_DIR
from mcd.denoise.arguments import int_in
from mcd.models.complexity import complexity

#: How far each trained method's share of its paper-size MACs may be from F's, relative.
SHARE_BAND = 0.15
#: The method every share is compared with: the paper's own (row F).
SHARE_REFERENCE = "F"


def trained_methods() -> list[str]:
    """Table 1's trained methods (:data:`mcd.config.methods.CATALOGUE`): the ones whose shares must be
    equal."""
    return [m.experiment for m in CATALOGUE if m.table1 and m.trainable]


def shares(capacity: str = "cpu", overrides: tuple[str, ...] = (), height: int = 1080,
           width: int = 1920) -> list[dict]:
    """One row per trained method: its MACs in ``capacity`` (with ``overrides``) and in the ``paper``
    profile at ``height x width``, the share (their ratio) and the share's ratio to F's."""
    rows = []
    for name in trained_methods():
        ours = _count(name, (f"capacity={capacity}", *overrides), height, width)[1]
        paper = _count(name, ("capacity=paper",), height, width)[1]
        rows.append({"name": name, "gmacs_1080p": round(ours, 2),
                     "paper_profile_gmacs_1080p": round(paper, 2), "share": ours / paper})
    reference = next(r["share"] for r in rows if r["name"] == SHARE_REFERENCE)
    for r in rows:
        r["ratio_to_F"] = r["share"] / reference
    return rows


@functools.cache
def _composed(name: str, overrides: tuple[str, ...]) -> DictConfig:
    """The config of experiment ``name`` with ``overrides``, composed once per process."""
    return compose([f"+experiment={name}", *overrides])


@functools.cache
def _count(name: str, overrides: tuple[str, ...], height: int, width: int) -> tuple[float, float]:
    """``(params M, GMACs)`` of ``name`` composed with ``overrides`` at ``height x width``, counted once per
    process: the table and the shares count the same models (the ``paper`` profile's, by default)."""
    return complexity(_composed(name, overrides), height, width)


def outside_band(rows: list[dict]) -> list[str]:
    """The methods whose share is more than :data:`SHARE_BAND` away from F's, each with its figures."""
    return [f"{r['name']}: {100 * r['share']:.1f}% of its paper-size MACs, {r['ratio_to_F']:.2f}x F's"
            for r in rows if abs(r["ratio_to_F"] - 1) > SHARE_BAND]


def table(experiments: list[str], capacity: str, height: int, width: int,
          unavailable: dict[str, str] | None = None) -> list[dict]:
    """One row per experiment: ours and the paper's params and GMACs (NaN where either is missing).

    A method whose optional package is missing (OIDN without ``pyoidn``) gets NaN and its reason in
    ``unavailable`` (name -> message) instead of stopping the table.
    """
    rows = []
    for name in experiments:
        overrides = (f"capacity={capacity}",)
        try:
            params, gmacs = _count(name, overrides, height, width)
        except ImportError as err:
            params, gmacs = math.nan, math.nan
            if unavailable is not None:
                unavailable[name] = str(err)
        paper = (paper_complexity(name, _composed(name, overrides).method.name)
                 or {"params_m": math.nan, "gmacs": math.nan})
        rows.append({"name": name, "params_m": round(params, 4), "gmacs_1080p": round(gmacs, 2),
                     "paper_params_m": paper["params_m"], "paper_gmacs": paper["gmacs"]})
    return rows


def _rel(ours: float, paper: float) -> str:
    return "" if math.isnan(paper) else f"{100 * (ours / paper - 1):+.1f}%"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m mcd.complexity",
                                     description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--capacity", default="paper", help="capacity profile (conf/capacity/<name>.yaml)")
    parser.add_argument("--experiments", nargs="*", default=None,
                        help="experiments to count (default: every one, rows A-M first)")
    parser.add_argument("--height", type=int_in(1, MAX_SIDE), default=1080)
    parser.add_argument("--width", type=int_in(1, MAX_SIDE), default=1920)
    parser.add_argument("-o", "--out", type=Path, default=None,
                        help="also write the table as CSV here (default: print only)")
    parser.add_argument("--shares", default="cpu",
                        help="print each trained method's share of its paper-size MACs in this profile, and "
                             "its ratio to F's ('none': skip)")
    parser.add_argument("--shares-out", type=Path, default=None, help="also write the shares as CSV here")
    args = parser.parse_args(argv)
    capacities = sorted(p.stem for p in (CONF_DIR / "capacity").glob("*.yaml"))
    for flag, value in (("--capacity", args.capacity), ("--shares", args.shares)):
        if value not in capacities and not (flag == "--shares" and value == "none"):
            parser.error(f"{flag} {value}: no such capacity profile (conf/capacity: {', '.join(capacities)})")
    unknown = sorted(set(args.experiments or ()) - set(experiment_names()))
    if unknown:
        parser.error(f"--experiments: no experiment {', '.join(unknown)} (conf/experiment: "
                     f"{', '.join(sorted(experiment_names()))})")
    unavailable: dict[str, str] = {}
    rows = table(args.experiments or experiment_names(), args.capacity, args.height, args.width, unavailable)
    print(f"capacity={args.capacity}, {args.width}x{args.height}, MACs = FlopCounterMode FLOPs / 2")
    print(f"{'name':<12}{'params_m':>10}{'paper':>8}{'diff':>8}{'gmacs':>10}{'paper':>9}{'diff':>8}")
    for r in rows:
        print(f"{r['name']:<12}{r['params_m']:>10.3f}{r['paper_params_m']:>8.3f}"
              f"{_rel(r['params_m'], r['paper_params_m']):>8}{r['gmacs_1080p']:>10.2f}"
              f"{r['paper_gmacs']:>9.2f}{_rel(r['gmacs_1080p'], r['paper_gmacs']):>8}"
              + (f"  unavailable: {unavailable[r['name']]}" if r["name"] in unavailable else ""))
    if args.out is not None:
        _write_csv(args.out, rows)
    if args.shares == "none":
        return
    share_rows = shares(args.shares, height=args.height, width=args.width)
    print(f"\nshares: capacity={args.shares} MACs / capacity=paper MACs, {args.width}x{args.height}; "
          f"band: within {100 * SHARE_BAND:.0f}% of {SHARE_REFERENCE}'s")
    print(f"{'name':<12}{'gmacs':>10}{'paper':>10}{'share':>8}{'x F':>7}")
    for r in share_rows:
        print(f"{r['name']:<12}{r['gmacs_1080p']:>10.2f}{r['paper_profile_gmacs_1080p']:>10.2f}"
              f"{100 * r['share']:>7.1f}%{r['ratio_to_F']:>7.2f}")
    for problem in outside_band(share_rows):
        print(f"outside the band: {problem}")
    if args.shares_out is not None:
        _write_csv(args.shares_out, [{**r, "share": round(r["share"], 4),
                                      "ratio_to_F": round(r["ratio_to_F"], 3)} for r in share_rows])


def _write_csv(path: Path, rows: list[dict]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()

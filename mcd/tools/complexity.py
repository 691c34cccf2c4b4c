"""``python -m mcd.tools.complexity``: params and 1920x1080 MACs of every registered experiment beside the
paper's (docs/benchmark.md "Metrics").

``python -m mcd.tools.complexity [--capacity paper] [--experiments A B ...] [-o PATH]`` prints the table; with
``-o`` it also writes it as CSV (``name, params_m, gmacs_1080p, paper_params_m, paper_gmacs``; NaN, and an
"unavailable" note in the printed table, for a method whose optional package is missing). It writes nothing
else: the tracked ``reports/complexity.csv`` changes only when asked for by name. Experiments are
:func:`mcd.config.experiment_names` (rows A-M from the component table, then ``conf/experiment/*.yaml``),
so a new method only needs its config (and its paper numbers in :mod:`mcd.methods`). The counting itself is
:mod:`mcd.models.complexity`.
"""

from __future__ import annotations

import argparse
import csv
import math
from pathlib import Path

from mcd.config import compose, experiment_names
from mcd.methods import paper_complexity
from mcd.models.complexity import complexity


def table(experiments: list[str], capacity: str, height: int, width: int,
          unavailable: dict[str, str] | None = None) -> list[dict]:
    """One row per experiment: ours and the paper's params and GMACs (NaN where either is missing).

    A method whose optional package is missing (OIDN without ``pyoidn``) gets NaN and its reason in
    ``unavailable`` (name -> message) instead of stopping the table.
    """
    rows = []
    for name in experiments:
        cfg = compose([f"+experiment={name}", f"capacity={capacity}"])
        try:
            params, gmacs = complexity(cfg, height, width)
        except ImportError as err:
            params, gmacs = math.nan, math.nan
            if unavailable is not None:
                unavailable[name] = str(err)
        paper = paper_complexity(name, cfg.method.name) or {"params_m": math.nan, "gmacs": math.nan}
        rows.append({"name": name, "params_m": round(params, 4), "gmacs_1080p": round(gmacs, 2),
                     "paper_params_m": paper["params_m"], "paper_gmacs": paper["gmacs"]})
    return rows


def _rel(ours: float, paper: float) -> str:
    return "" if math.isnan(paper) else f"{100 * (ours / paper - 1):+.1f}%"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m mcd.tools.complexity",
                                     description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    parser.add_argument("--capacity", default="paper", help="capacity profile (conf/capacity/<name>.yaml)")
    parser.add_argument("--experiments", nargs="*", default=None,
                        help="experiments to count (default: every one, rows A-M first)")
    parser.add_argument("--height", type=int, default=1080)
    parser.add_argument("--width", type=int, default=1920)
    parser.add_argument("-o", "--out", type=Path, default=None,
                        help="also write the table as CSV here (default: print only)")
    args = parser.parse_args(argv)
    unavailable: dict[str, str] = {}
    rows = table(args.experiments or experiment_names(), args.capacity, args.height, args.width, unavailable)
    print(f"capacity={args.capacity}, {args.width}x{args.height}, MACs = FlopCounterMode FLOPs / 2")
    print(f"{'name':<12}{'params_m':>10}{'paper':>8}{'diff':>8}{'gmacs':>10}{'paper':>9}{'diff':>8}")
    for r in rows:
        print(f"{r['name']:<12}{r['params_m']:>10.3f}{r['paper_params_m']:>8.3f}"
              f"{_rel(r['params_m'], r['paper_params_m']):>8}{r['gmacs_1080p']:>10.2f}"
              f"{r['paper_gmacs']:>9.2f}{_rel(r['gmacs_1080p'], r['paper_gmacs']):>8}"
              + (f"  unavailable: {unavailable[r['name']]}" if r["name"] in unavailable else ""))
    if args.out is None:
        return
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()

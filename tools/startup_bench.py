"""``python tools/startup_bench.py``: how long each command takes to answer ``--help``, in a fresh interpreter
as a user runs it (docs/architecture.md, "Start-up"). Prints, per command, the median and the range over
``--runs`` runs of the child's CPU time (user + system, which a loaded machine inflates less than wall time)
and of its wall time, with the machine beside them; ``--json`` writes the rows too.

The goal is about 1 s of CPU per command; whether the heavy libraries stay off the path to ``--help`` is
checked by ``tests/test_startup.py``, deterministically, not by time.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

#: The commands a user starts with ``--help``: the Hydra apps, the report, the benchmark and ``mcd-denoise``.
COMMANDS = ("mcd.run", "mcd.render", "mcd.plan", "mcd.report", "mcd.bench", "mcd.denoise")
REPO = Path(__file__).resolve().parents[1]


def time_help(module: str) -> tuple[float, float]:
    """``(CPU seconds, wall seconds)`` of one ``python -m <module> --help`` in a fresh interpreter."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", module, "--help"], cwd=REPO, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(REPO)}, check=False)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode != 0:
        raise SystemExit(f"error: python -m {module} --help exited {proc.returncode}: {proc.stderr[-1000:]}")
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), wall


def main(argv: list[str] | None = None) -> None:
    """Time every command's ``--help`` ``--runs`` times and print one row per command."""
    import torch

    from mcd.core.machine import device_name
    from mcd.core.provenance import short_commit

    ap = argparse.ArgumentParser(prog="python tools/startup_bench.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=3, help="runs per command (default 3)")
    ap.add_argument("--commands", nargs="+", default=list(COMMANDS), help="modules to time (default: all)")
    ap.add_argument("--json", type=Path, help="also write the rows to this JSON file")
    args = ap.parse_args(argv)
    print(f"# python -m <command> --help, {args.runs} runs each; commit {short_commit()}; "
          f"{device_name(torch.device('cpu'))}; load average {os.getloadavg()[0]:.1f}")
    print(f"{'command':<14} {'CPU median (s)':>15} {'CPU range (s)':>15} {'wall median (s)':>16}")
    rows = []
    for module in args.commands:
        cpu, wall = zip(*(time_help(module) for _ in range(args.runs)), strict=True)
        rows.append({"command": module, "cpu_s": list(cpu), "wall_s": list(wall)})
        print(f"{module:<14} {statistics.median(cpu):>15.2f} {f'{min(cpu):.2f}-{max(cpu):.2f}':>15} "
              f"{statistics.median(wall):>16.2f}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))


if __name__ == "__main__":
    main()

"""Whether two reports agree on the jobs they share (docs/benchmark.md "Reports"). Not a test: prints figures.

    python benchmarks/report_agreement.py reports/A reports/B

Reads each report's ``per_frame/per_frame.csv`` (one row per experiment, test scene and frame) and, for every
experiment both hold, prints per test scene the frames both scored and the mean and largest difference of
PSNR (B - A). A job that needs no training (the noisy input, OIDN) scores the same frames the same on the same
store, so its differences say whether two reports ran on the same data: reports/small_converged_part2 ran on a
store rendered again on a second machine.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pandas as pd

KEYS = ["experiment", "scene", "frame"]


def agreement(a: pd.DataFrame, b: pd.DataFrame) -> pd.DataFrame:
    """Per shared experiment and scene: frames, mean and largest |.| of PSNR B - A."""
    both = a[KEYS + ["psnr"]].merge(b[KEYS + ["psnr"]], on=KEYS, suffixes=("_a", "_b"))
    both["d"] = both["psnr_b"] - both["psnr_a"]
    return both.groupby(["experiment", "scene"]).agg(
        frames=("d", "size"), mean_db=("d", "mean"), max_abs_db=("d", lambda d: d.abs().max())
    )


def main(argv: list[str]) -> None:
    if len(argv) != 2:
        sys.exit(__doc__)
    tables = []
    for report in map(Path, argv):
        path = report / "per_frame" / "per_frame.csv"
        if not path.is_file():
            sys.exit(f"{path}: no per-frame table (python -m mcd.report writes one for finished runs)")
        tables.append(pd.read_csv(path))
    result = agreement(*tables)
    if result.empty:
        sys.exit(f"{argv[0]} and {argv[1]} share no experiment, scene and frame")
    print(f"PSNR of {argv[1]} - {argv[0]} on the frames both scored (dB)")
    print(result.to_string(float_format=lambda x: f"{x:+.4f}"))


if __name__ == "__main__":
    main(sys.argv[1:])

"""Where a run's rMSE comes from, by reference luminance (docs/benchmark.md rMSE; not a test: prints figures).

    python benchmarks/rmse_by_luminance.py <run dir> [<run dir> ...] [--frame 0000]

Reads the saved test samples of each run (``<run>/samples/<scene>/<frame>_{output,noisy,reference}.exr``)
and prints, per scene: the share of pixels in each reference-luminance bin, the output's and the noisy input's
rMSE (``mcd.metrics.rmse``) with the part each bin contributes, and the mean and signed error of output and
input on pixels darker than 0.1.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mcd.data.exr import read_exr
from mcd.metrics import RMSE_EPS, rmse

BINS = ((0.0, 0.01), (0.01, 0.1), (0.1, 1.0), (1.0, np.inf))


def load(path: Path) -> np.ndarray:
    image = read_exr(path)
    image = next(iter(image.values())) if isinstance(image, dict) else image
    return np.asarray(image, np.float64)[..., :3]


def by_bin(x: np.ndarray, ref: np.ndarray, lum: np.ndarray) -> list[float]:
    """Each luminance bin's part of ``rmse(x, ref)`` (the parts sum to it)."""
    err = ((x - ref) ** 2 / (ref**2 + RMSE_EPS)).mean(-1)
    return [float(err[(lum >= lo) & (lum < hi)].sum() / err.size) for lo, hi in BINS]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", type=Path)
    ap.add_argument("--frame", default="0000")
    args = ap.parse_args()
    print("bins (reference luminance):", ", ".join(f"[{lo}, {hi})" for lo, hi in BINS))
    for run in args.runs:
        for scene in sorted(p for p in (run / "samples").iterdir() if p.is_dir()):
            ref, out, noisy = (load(scene / f"{args.frame}_{kind}.exr")
                               for kind in ("reference", "output", "noisy"))
            lum = ref.mean(-1)
            share = [float(((lum >= lo) & (lum < hi)).mean()) for lo, hi in BINS]
            dark = lum < 0.1
            print(f"{run} {scene.name} frame {args.frame}: pixel share {np.round(share, 3).tolist()}")
            for name, x in (("output", out), ("noisy", noisy)):
                parts = np.round(by_bin(x, ref, lum), 3).tolist()
                print(f"  {name:6s} rMSE {rmse(x, ref):.3f} by bin {parts}; "
                      f"dark pixels: mean |error| {np.abs(x - ref)[dark].mean():.4f}, "
                      f"mean error {(x - ref)[dark].mean():+.4f}")


if __name__ == "__main__":
    main()

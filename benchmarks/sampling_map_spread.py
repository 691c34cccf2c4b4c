"""How a trained run spreads its adaptive samples over the test frames (docs/method.md "Adaptive sampling";
issue 12). Not a test: prints figures.

    python benchmarks/sampling_map_spread.py RUN_DIR [RUN_DIR ...]

Reads each run's saved sampling maps (``samples/<scene>/<frame>_sampling_map.exr``, the frames of
``train.sample_frames``; the map holds ``m``, the adaptive samples per pixel beside the 1-spp ``c_1``, mean
``s - 1``) and its per-frame scores (``frames.csv``). Per run and test scene: the budget, the scene's test
PSNR, and over the saved maps the share of pixels that get no adaptive sample (they average the one sample of
``c_1``), at most a quarter of the mean, and at the per-pixel cap ``2^(t+1) - 1`` (``method.sampling.levels``
= ``t``), and the coefficient of variation of ``m``. A map near uniform has the first three near 0; one that
starves part of the frame to feed the rest has large shares at both ends.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd
from omegaconf import OmegaConf

from mcd.data.exr import read_exr
from mcd.sampling.normalise import cap_for_levels


def spread(run: Path) -> pd.DataFrame:
    cfg = OmegaConf.load(run / "resolved_config.yaml")
    cap = cap_for_levels(int(cfg.method.sampling.levels))
    frames = pd.read_csv(run / "frames.csv")
    rows = []
    for scene_dir in sorted(p for p in (run / "samples").iterdir() if p.is_dir()):
        maps = [read_exr(p) for p in sorted(scene_dir.glob("*_sampling_map.exr"))]
        if not maps:
            continue
        m = np.concatenate([x.reshape(-1, x.shape[-1])[:, 0] for x in maps])
        mean = float(m.mean())
        rows.append({"run": run.name, "spp": float(cfg.budget), "scene": scene_dir.name,
                     "PSNR": float(frames.loc[frames["scene"] == scene_dir.name, "psnr"].mean()),
                     "m mean": mean, "share m=0": float((m == 0).mean()),
                     "share m<=mean/4": float((m <= mean / 4).mean()),
                     "share at cap": float((m >= cap).mean()),
                     "cv": float(m.std() / mean) if mean > 0 else float("nan")})
    return pd.DataFrame(rows)


def main(argv: list[str]) -> None:
    runs = [Path(a) for a in argv]
    missing = [str(r) for r in runs if not (r / "samples").is_dir() or not (r / "frames.csv").is_file()]
    if not runs or missing:
        sys.exit("usage: sampling_map_spread.py RUN_DIR [...] (finished runs with samples/ and frames.csv); "
                 f"not such a run: {', '.join(missing)}")
    table = pd.concat([spread(r) for r in runs], ignore_index=True)
    if table.empty:
        sys.exit("no saved sampling maps in these runs (runs without adaptive sampling save none)")
    with pd.option_context("display.width", 200, "display.max_rows", 500):
        print(table.round(3).to_string(index=False))


if __name__ == "__main__":
    main(sys.argv[1:])

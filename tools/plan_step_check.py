"""How well the plan's training step (:func:`mcd.lit.workload.train_step`) predicts the step it plans
(notes/scaling_plan.md "The plan re-measured with the configured step"): per method, the step measured three
ways: the whole batch at ``--small`` / 2 and ``--small`` extrapolated to the crop, one clip at the same crops
extrapolated and scaled by ``train.batch_size``, and the whole batch at the crop itself (the plan's way where
the crop is at most ``plan.step_crop``), the reference of the other two. The three alternate, ``--repeat``
rounds, in one process; CPU seconds of one thread, and the wall seconds each measurement took (the model's
build and warm-up steps included). Run with ``OMP_NUM_THREADS=1``:

    OMP_NUM_THREADS=1 PYTHONPATH=. python tools/plan_step_check.py --methods F,ntasad,C,A --data small
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

import torch

from mcd.config.compose import compose
from mcd.core.machine import device_name
from mcd.core.provenance import short_commit
from mcd.lit.workload import train_step


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--methods", default="F,ntasad", help="experiments, comma-separated (+experiment=<name>)")
    ap.add_argument("--data", default="small", help="data profile")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a config override")
    ap.add_argument("--small", type=int, default=64, help="the larger of the two small crops")
    ap.add_argument("--repeat", type=int, default=2, help="rounds of the three measurements")
    args = ap.parse_args()
    print(f"commit {short_commit()}; {device_name(torch.device('cpu'))}; torch {torch.__version__}; "
          f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for method in args.methods.split(","):
        cfg = compose([f"+experiment={method}", f"data={args.data}", *args.set])
        small, crop = args.small, int(cfg.data.train_crop)
        ways = {"batch": (small, None), "clip": (small, 1), "at the crop": (crop, None)}
        got: dict[str, list[float]] = {k: [] for k in ways}
        wall: dict[str, list[float]] = {k: [] for k in ways}
        for _ in range(args.repeat):
            for k, (step_crop, batch) in ways.items():
                t0 = time.perf_counter()
                r = train_step(cfg, step_crop, batch=batch)
                wall[k].append(time.perf_counter() - t0)
                got[k].append(r["seconds"])
        med = {k: statistics.median(v) for k, v in got.items()}
        print(f"{method} {args.data} ({r['precision']}, channels-last {r['observed']['channels_last']}, "
              f"batch {r['batch']} x {r['clip_len']} frames at {crop}): " + "; ".join(
                  f"{k} {' '.join(f'{s:.3f}' for s in v)} s (median {med[k]:.3f}, "
                  f"{med[k] / med['at the crop']:.2f}x; the measurement took "
                  f"{statistics.median(wall[k]):.1f} s)"
                  for k, v in got.items()), flush=True)
    print(f"load average at the end {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()

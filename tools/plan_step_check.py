"""How well the plan's training step (:func:`mcd.lit.workload.train_step`) predicts the step it plans
(notes/scaling_plan.md "The plan re-measured with the configured step"): per method, the step measured three
ways: the whole batch at ``--small`` / 2 and ``--small`` extrapolated to the crop, one clip at the same crops
extrapolated and scaled by ``train.batch_size``, and the whole batch at the crop itself (the plan's way where
the crop is at most ``plan.step_crop``), the reference of the other two. The three alternate, ``--repeat``
rounds, in one process; CPU seconds of one thread, and the wall seconds each measurement took (the model's
build and warm-up steps included). ``--real N``: also, each round, the median of ``N`` steps of the study's
step on the profile's stored batches after a warm-up one (:func:`tools.train_step_ab.step_call`, CPU seconds;
its step also reloads the start weights and copies the gradients), the reference then. Run with
``OMP_NUM_THREADS=1``:

    OMP_NUM_THREADS=1 PYTHONPATH=. python tools/plan_step_check.py --methods F,ntasad,C,A --data small
    OMP_NUM_THREADS=1 PYTHONPATH=. python tools/plan_step_check.py --methods F,ntasad --ways "at the crop" \
        --real 3 --repeat 3 --set paths.data_dir=/path/to/data --set data.verify_checksums=never
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
from tools.train_step_ab import step_call


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--methods", default="F,ntasad", help="experiments, comma-separated (+experiment=<name>)")
    ap.add_argument("--data", default="small", help="data profile")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE", help="a config override")
    ap.add_argument("--small", type=int, default=64, help="the larger of the two small crops")
    ap.add_argument("--repeat", type=int, default=2, help="rounds of the measurements")
    ap.add_argument("--ways", default="batch,clip,at the crop", help="of batch, clip, at the crop")
    ap.add_argument("--real", type=int, default=0,
                    help="also, each round, this many steps of tools/train_step_ab.py on the store's batches")
    args = ap.parse_args()
    print(f"commit {short_commit()}; {device_name(torch.device('cpu'))}; torch {torch.__version__}; "
          f"load average {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for method in args.methods.split(","):
        cfg = compose([f"+experiment={method}", f"data={args.data}", *args.set])
        small, crop = args.small, int(cfg.data.train_crop)
        every = {"batch": (small, None), "clip": (small, 1), "at the crop": (crop, None)}
        ways = {k: v for k, v in every.items() if k in args.ways.split(",")}
        got: dict[str, list[float]] = {k: [] for k in [*ways, *(["real"] if args.real else [])]}
        wall: dict[str, list[float]] = {k: [] for k in got}
        if args.real:
            call, batches, _ = step_call(method, args.data, args.set, args.real + 1, synthetic=False)
        for _ in range(args.repeat):
            for k, (step_crop, batch) in ways.items():
                t0 = time.perf_counter()
                r = train_step(cfg, step_crop, batch=batch)
                wall[k].append(time.perf_counter() - t0)
                got[k].append(r["seconds"])
            if args.real:
                t0, runs = time.perf_counter(), []
                for i, b in enumerate(batches):
                    c0 = time.process_time()
                    call(b)
                    if i:  # the first: a warm-up
                        runs.append((time.process_time() - c0) / torch.get_num_threads())
                wall["real"].append(time.perf_counter() - t0)
                got["real"].append(statistics.median(runs))
        med = {k: statistics.median(v) for k, v in got.items()}
        ref = "real" if args.real else "at the crop"
        print(f"{method} {args.data} ({r['precision']}, channels-last {r['observed']['channels_last']}, "
              f"batch {r['batch']} x {r['clip_len']} frames at {crop}): " + "; ".join(
                  f"{k} {' '.join(f'{s:.3f}' for s in v)} s (median {med[k]:.3f}, "
                  f"{med[k] / med[ref]:.2f}x; the measurement took {statistics.median(wall[k]):.1f} s)"
                  for k, v in got.items()), flush=True)
    print(f"load average at the end {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()

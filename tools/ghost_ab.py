"""A/B of the replicate-padded Fast GhostConv paths (docs/inference.md "Replicate padding"): row F's frame
time and training step with them and without them, in one process, the two alternating call by call.

"Without" patches :func:`mcd.models.cpu_fast.ghost_conv.replicate_path_applies` and ``merged_applies`` (as
:mod:`mcd.models.ghost_conv` sees them) to say no, which is the code before those paths: every replicate
Ghost conv pads with ``F.pad`` and runs the plain grouped conv (in training: dense with the block-diagonal
weight) and the point-wise conv. Everything else is the same model, weights and inputs.

- ``frame``: ``capacity=paper`` (as ``python -m mcd.bench speed``), ``--size`` synthetic buffers
  (``mcd.bench.speed.frame_buffers``), channels-last, inference mode, bf16 autocast where the CPU has it
  (``--dtype``).
- ``train``: the configured capacity (``capacity=cpu``, the scaling study's), ``--batch`` crops of
  ``--crop`` pixels (``mcd.models.complexity.dummy_batch``) in train mode, bf16 autocast where the CPU has it
  (``trainer.precision=auto``'s choice), forward, an L1 loss of the output against the reference, backward
  and an Adam step. The paper's loss (VGG features, temporal terms) is not in it: what it adds to a step
  is the same with and without.

Prints each call's ms, the medians and the ratio without/with. Run with ``OMP_NUM_THREADS`` set.

    PYTHONPATH=. python tools/ghost_ab.py --what frame,train --size 960x540 --repeat 5
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager

import torch

from mcd.bench.speed import frame_buffers, parse_size
from mcd.config.compose import compose
from mcd.core.machine import device_name
from mcd.core.provenance import short_commit
from mcd.lit.precision import autocast_to, cpu_bf16_supported
from mcd.models import build, ghost_conv
from mcd.models.complexity import dummy_batch
from mcd.models.latency import model_inputs

CPU = torch.device("cpu")


@contextmanager
def without_replicate_paths() -> Iterator[None]:
    """The Fast GhostConv block as it ran before the replicate paths."""
    saved = ghost_conv.replicate_path_applies, ghost_conv.merged_applies
    ghost_conv.replicate_path_applies = lambda *args: False
    ghost_conv.merged_applies = lambda *args: False
    try:
        yield
    finally:
        ghost_conv.replicate_path_applies, ghost_conv.merged_applies = saved


def frame_call(size: str, dtype: torch.dtype | None) -> Callable[[], None]:
    """One inference call of row F at ``size``."""
    h, w = parse_size(size)
    model = build(compose(["+experiment=F", "capacity=paper"])).eval().to(memory_format=torch.channels_last)
    buffers, _ = frame_buffers(set(model.required_buffers()) - {"ref"}, h, w, None)
    x = model_inputs(model, buffers, CPU, channels_last=True)

    def call() -> None:
        model.reset()
        with torch.inference_mode(), autocast_to(CPU, dtype):
            model(x)

    return call


def train_call(crop: int, batch: int, dtype: torch.dtype | None) -> Callable[[], None]:
    """One training step of row F (capacity ``cpu``) on ``batch`` crops of ``crop`` pixels."""
    torch.manual_seed(0)
    model = build(compose(["+experiment=F"])).train()
    x = dummy_batch(model, crop, crop, "cpu", batch=batch)
    ref = torch.rand(batch, 3, crop, crop)
    x["ref"] = ref                                    # the adaptive render's gradient (DASR) reads it
    opt = torch.optim.Adam(model.parameters(), lr=1e-5)

    def call() -> None:
        model.reset()
        with autocast_to(CPU, dtype):
            out = model(x)["output"]
        loss = (out.float() - ref).abs().mean()
        opt.zero_grad(set_to_none=True)
        loss.backward()
        opt.step()

    return call


def ab(name: str, call: Callable[[], None], warmup: int, repeat: int) -> None:
    """Alternate ``call`` with and without the replicate paths; print the medians and their ratio."""
    times: dict[str, list[float]] = {"with": [], "without": []}

    def timed(which: str) -> float:
        if which == "without":
            with without_replicate_paths():
                t0 = time.perf_counter()
                call()
        else:
            t0 = time.perf_counter()
            call()
        return (time.perf_counter() - t0) * 1e3

    for _ in range(warmup):
        timed("without")
        timed("with")
    for i in range(repeat):
        for which in (("without", "with") if i % 2 == 0 else ("with", "without")):
            times[which].append(timed(which))
    med = {k: statistics.median(v) for k, v in times.items()}
    for k, v in times.items():
        print(f"{name} {k:7s} ms: " + " ".join(f"{t:.1f}" for t in v) + f"  median {med[k]:.1f}")
    print(f"{name}: without / with = {med['without'] / med['with']:.2f}x")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--what", default="frame,train", help="frame and/or train, comma-separated")
    ap.add_argument("--size", default="960x540", help="frame size: 1080p, 256 or <W>x<H>")
    ap.add_argument("--crop", type=int, default=96, help="training crop (the scaling study's: 96)")
    ap.add_argument("--batch", type=int, default=4, help="training batch (train=cpu: 4)")
    ap.add_argument("--dtype", choices=("bf16", "fp32"), help="default: bf16 where the CPU has it")
    ap.add_argument("--warmup", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    dtype = torch.bfloat16 if (args.dtype or ("bf16" if cpu_bf16_supported() else "fp32")) == "bf16" else None
    print(f"commit {short_commit()}; {device_name(CPU)}; torch {torch.__version__}; "
          f"{torch.get_num_threads()} thread(s); dtype {'bf16' if dtype else 'fp32'}")
    what = args.what.split(",")
    if "frame" in what:
        ab(f"frame {args.size}", frame_call(args.size, dtype), args.warmup, args.repeat)
    if "train" in what:
        ab(f"train step b{args.batch} crop {args.crop}", train_call(args.crop, args.batch, dtype),
           args.warmup, args.repeat)


if __name__ == "__main__":
    main()

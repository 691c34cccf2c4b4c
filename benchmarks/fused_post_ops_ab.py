"""Rows at 1080p on the CPU with oneDNN's fused post-ops, against the same model running the plain operations
(docs/inference.md, "Fused post-ops").

One process per call of this script; per method (``--methods``, default ``F,unet``; capacity ``model=paper``,
seeded weights), the bench's input frame (the first test scene of ``--data``, read through the store and
tiled to 1920x1080) on the fp32 channels-last path (``--dtype bf16``: bf16 autocast and channels-last, where
the CPU computes bf16) under ``torch.inference_mode``, freed memory kept
(mcd/allocator.py). Two variants alternate call by call after ``--warmup`` calls each, timed in wall-clock
seconds (both threads work, so thread CPU time would miss half of it):

- ``plain``: :func:`mcd.models.fused_conv.applies` answers no, so every block runs its plain operations
  (conv, then ReLU; the decoder's concatenation; ``add_`` per part);
- ``fused``: the code as it is.

    OMP_NUM_THREADS=2 python benchmarks/fused_post_ops_ab.py --data small --reps 5 [--dtype bf16]
"""

from __future__ import annotations

import argparse
import statistics
import time

import torch

from mcd import allocator
from mcd.bench import StoreFrame, compose_cfg, device_name, frame_buffers, model_inputs, store_frame
from mcd.lit.precision import cpu_bf16_supported
from mcd.models import build, fused_conv

VARIANTS = ("plain", "fused")
APPLIES = fused_conv.applies


def use(variant: str) -> None:
    fused_conv.applies = APPLIES if variant == "fused" else (lambda *_: False)


def measure(method: str, source: StoreFrame, warmup: int, reps: int, bf16: bool) -> str:
    """One method's table row: both variants' times, the ratio of their medians, their outputs' difference."""
    torch.manual_seed(0)
    model = build(compose_cfg(method, ["model=paper"])).eval().to(memory_format=torch.channels_last)
    buffers, _ = frame_buffers(set(model.required_buffers()) - {"ref"}, 1080, 1920, source)
    x = model_inputs(model, buffers, torch.device("cpu"), channels_last=True)
    times: dict[str, list[float]] = {v: [] for v in VARIANTS}
    outputs = {}

    def call(variant: str) -> float:
        use(variant)
        model.reset()
        t0 = time.perf_counter()
        with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
            outputs[variant] = model(x)["output"].float()
        return time.perf_counter() - t0

    for _ in range(warmup):
        for v in VARIANTS:
            call(v)
    for _ in range(reps):
        for v in VARIANTS:
            times[v].append(call(v))
    use("fused")
    diff = float((outputs["plain"] - outputs["fused"]).abs().max())
    med = {v: statistics.median(times[v]) for v in VARIANTS}
    return (f"| {method} | {' '.join(f'{t:.2f}' for t in times['plain'])} (median {med['plain']:.2f}) | "
            f"{' '.join(f'{t:.2f}' for t in times['fused'])} (median {med['fused']:.2f}) | "
            f"{med['plain'] / med['fused']:.3f}x | {diff:.2e} (max |output| "
            f"{float(outputs['plain'].abs().max()):.3g}) |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--methods", default="F,unet")
    parser.add_argument("--data", help="data profile whose store holds the input frame (default: config's)")
    parser.add_argument("--reps", type=int, default=5)
    parser.add_argument("--warmup", type=int, default=2)
    parser.add_argument("--dtype", choices=("fp32", "bf16"), default="fp32")
    args = parser.parse_args()
    if args.dtype == "bf16" and not cpu_bf16_supported():
        parser.error("--dtype bf16: this CPU has no native bf16 (avx512_bf16 / amx)")
    memory = allocator.apply("keep")
    source = store_frame(args.data, None)
    print(f"{device_name(torch.device('cpu'))}, {torch.get_num_threads()} thread(s), 1920x1080, "
          f"{args.dtype} channels-last, {memory}; wall s per call, {args.warmup} warm-up call(s) per "
          "variant\n")
    print("| method | plain | fused | median plain / fused | max abs difference of the outputs |")
    print("|---|---|---|---|---|")
    for method in args.methods.split(","):
        print(measure(method, source, args.warmup, args.reps, args.dtype == "bf16"))


if __name__ == "__main__":
    main()

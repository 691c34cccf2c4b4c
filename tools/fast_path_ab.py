"""A/B of one inference fast path (docs/inference.md "Fast paths"): a method's frame time with it and
without it, in one process, the two alternating call by call.

``--path`` picks what "without" turns off; every other fast path runs in both, so what differs is that path:

- ``output_bound``: :mod:`mcd.models.output_bound` is handed a switch that says no (its reference
  formulations: ``unfold`` and ``topk``, ``max_pool2d``, ``torch.quantile``, the render's 3 x 3 mean on every
  frame);
- ``head_conv``: the kernel-map head's replicate-padded last convolution runs as ``nn.Conv2d`` (``F.pad``,
  then the conv) instead of :func:`mcd.models.cpu_fast.replicate.replicate_conv`.

Same model, weights and inputs: ``capacity=paper`` (as ``python -m mcd.bench speed``), ``--size`` synthetic
buffers (``mcd.bench.speed.frame_buffers``), channels-last, inference mode, bf16 autocast where the CPU has
it (``--dtype``). The output steps run in the model's forward (mcd/models/output_steps.py), so the frame is
the bench's; freed memory is kept, as the bench keeps it (:mod:`mcd.core.allocator`). Prints, per method,
for the frame and for the stage the path runs in (exclusive, :class:`mcd.core.stages.StageClock`): each
call's ms, the medians and their ratio without/with, and the median of each pair's ratio (the two calls of a
pair run back to back, so it follows a changing load better); then whether the two outputs are equal. Run
with ``OMP_NUM_THREADS`` set.

    PYTHONPATH=. python tools/fast_path_ab.py --path output_bound --methods F,unet --size 1080p --repeat 5
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager, nullcontext
from types import SimpleNamespace

import torch

from mcd.bench.speed import frame_buffers, parse_size
from mcd.config.compose import compose
from mcd.core import allocator
from mcd.core.machine import device_name
from mcd.core.provenance import short_commit
from mcd.core.stages import StageClock
from mcd.lit.precision import autocast_to, cpu_bf16_supported
from mcd.models import build, kernel_pool, output_bound

CPU = torch.device("cpu")


#: ``--path`` -> (module, attribute, what it is replaced by "without", the stage label it runs in).
PATHS = {
    "output_bound": (output_bound, "fast_paths", SimpleNamespace(enabled=lambda: False), "output steps"),
    "head_conv": (kernel_pool, "replicate_conv_applies", lambda *args: False, "kernel-map head"),
}


@contextmanager
def without(path: str) -> Iterator[None]:
    """``path``'s reference formulation; the other fast paths as they are."""
    module, name, off, _ = PATHS[path]
    saved = getattr(module, name)
    setattr(module, name, off)
    try:
        yield
    finally:
        setattr(module, name, saved)


def frame_call(method: str, size: str, dtype: torch.dtype | None,
               label: str) -> Callable[[], tuple[torch.Tensor, float]]:
    """One inference call of ``method`` at ``size``; returns its output and the exclusive ms of the stage
    ``label`` (:class:`mcd.core.stages.StageClock`, every path ending in it)."""
    from mcd.models.latency import model_inputs

    h, w = parse_size(size)
    model = build(compose([f"+experiment={method}", "capacity=paper"])).eval()
    model = model.to(memory_format=torch.channels_last)
    buffers, _ = frame_buffers(set(model.required_buffers()) - {"ref"}, h, w, None)
    x = model_inputs(model, buffers, CPU, channels_last=True)

    def call() -> tuple[torch.Tensor, float]:
        if hasattr(model, "reset"):
            model.reset()
        with torch.inference_mode(), autocast_to(CPU, dtype), StageClock(CPU) as clock:
            out = model(x)["output"]
        return out, sum(ms for p, ms in clock.totals().items() if p.rsplit("/", 1)[-1] == label)

    return call


def ab(name: str, path: str, call: Callable[[], tuple[torch.Tensor, float]], warmup: int,
       repeat: int) -> None:
    """Alternate ``call`` with and without ``path``; print the medians of the frame and of the stage it runs
    in, their ratios and whether the outputs agree."""
    times: dict[str, list[float]] = {"with": [], "without": []}
    stages: dict[str, list[float]] = {"with": [], "without": []}
    outputs: dict[str, torch.Tensor] = {}

    def timed(which: str) -> float:
        with without(path) if which == "without" else nullcontext():
            t0 = time.perf_counter()
            outputs[which], ms = call()
            wall = (time.perf_counter() - t0) * 1e3
        stages[which].append(ms)
        return wall

    for _ in range(warmup):
        timed("without")
        timed("with")
    for v in stages.values():
        v.clear()
    for i in range(repeat):
        for which in (("without", "with") if i % 2 == 0 else ("with", "without")):
            times[which].append(timed(which))
    label = PATHS[path][3]
    for what, table in (("frame", times), (label, stages)):
        med = {k: statistics.median(v) for k, v in table.items()}
        for k, v in table.items():
            print(f"{name} {what} {k:7s} ms: " + " ".join(f"{t:.1f}" for t in v) + f"  median {med[k]:.1f}")
        pairs = statistics.median(a / b for a, b in zip(table["without"], table["with"], strict=True))
        print(f"{name} {what}: without / with = {med['without'] / med['with']:.2f}x of the medians "
              f"(saved {med['without'] - med['with']:.1f} ms), {pairs:.2f}x the median of the pairs' ratios")
    same = torch.equal(outputs["with"], outputs["without"])
    rel = float((outputs["with"].float() - outputs["without"].float()).abs().max()
                / outputs["without"].float().abs().max().clamp_min(1e-30))
    print(f"{name}: outputs {'equal' if same else f'differ by at most {rel:.2e} of the largest'}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--path", choices=sorted(PATHS), required=True, help="the fast path to turn off")
    ap.add_argument("--methods", default="F,unet", help="experiments, comma-separated")
    ap.add_argument("--size", default="1080p", help="frame size: 1080p, 256 or <W>x<H>")
    ap.add_argument("--dtype", choices=("bf16", "fp32"), help="default: bf16 where the CPU has it")
    ap.add_argument("--warmup", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    memory = allocator.apply("keep")                                           # as the bench does
    dtype = torch.bfloat16 if (args.dtype or ("bf16" if cpu_bf16_supported() else "fp32")) == "bf16" else None
    print(f"commit {short_commit()}; {device_name(CPU)}; torch {torch.__version__}; "
          f"{torch.get_num_threads()} thread(s); dtype {'bf16' if dtype else 'fp32'}; without: {args.path}; "
          f"allocator: {memory}")
    for method in args.methods.split(","):
        ab(f"{method} {args.size}", args.path, frame_call(method, args.size, dtype, PATHS[args.path][3]),
           args.warmup, args.repeat)


if __name__ == "__main__":
    main()

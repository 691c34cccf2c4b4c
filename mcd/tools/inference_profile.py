"""``python -m mcd.bench profile``: where a two-stage method's inference time goes, stage by stage
(docs/inference.md).

The method (``--method``, default row F; ``capacity=paper`` unless an override says otherwise) reads one
frame of the store (as ``python -m mcd.bench`` does: a store read, tiled to ``--size``), runs ``--warmup``
calls and then the reported call (the next, while a call faults pages in), each under ``torch.profiler``
(whose own allocations reshape the heap that ``mcd/allocator.py`` keeps, so the warm-ups must include them;
the page faults of the reported call are printed, 0 once the heap has settled) on the CPU, under
``torch.inference_mode``, along the path
``--dtype`` (default ``bf16`` with channels-last where the CPU computes bf16 natively, else ``fp32``
channels-last). Each stage is a ``torch.profiler.record_function`` label in the model
(:data:`mcd.models.two_stage.STAGES` and the nested ``map normalisation``, ``kernel-map head``, ``kernel
application``, ``PP``, ``SA``); the table gives its time (inclusive of nested stages), its share of the call,
its MACs (``FlopCounterMode`` per module on the meta device, as :mod:`mcd.models.complexity` counts them) and
the achieved GMAC/s. ``other`` is the call minus the four top-level stages (input preparation, concatenations,
the colour transform).
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from pathlib import Path

import torch
from torch import nn
from torch.profiler import ProfilerActivity, profile

from mcd import allocator
from mcd.config import compose, exit_on_renamed
from mcd.lit.precision import autocast_to, cpu_bf16_supported
from mcd.machine import device_name
from mcd.models.complexity import dummy_batch, flop_counter_mode
from mcd.models.latency import model_inputs
from mcd.models.position_pooling import PositionAwarePool
from mcd.models.semantic_alignment import SemanticAlignment
from mcd.models.two_stage import STAGES, TwoStage
from mcd.provenance import short_commit
from mcd.tools.bench import (
    InferencePath,
    frame_buffers,
    parse_size,
    store_frame,
)

#: Every label, as ``(name, depth)`` in the printed order (depth 1: nested in the stage above it).
LABELS = (
    ("F_s", 0),
    ("adaptive render", 0),
    ("map normalisation", 1),
    ("kernel pool", 0),
    ("kernel-map head", 1),
    ("kernel application", 1),
    ("F_d", 0),
    ("PP", 1),
    ("SA", 1),
)


def stage_modules(model: TwoStage) -> dict[str, list[nn.Module]]:
    """The modules whose MACs each label runs (labels without modules hold no counted MACs)."""
    sampler = model.sampler
    return {
        "F_s": [sampler.unet] if sampler is not None else [],
        "kernel pool": [m for m in (sampler.head, sampler.pool) if m is not None] if sampler else [],
        "kernel-map head": [sampler.head] if sampler is not None and sampler.head is not None else [],
        "F_d": [model.denoiser],
        "PP": [m for m in model.denoiser.modules() if isinstance(m, PositionAwarePool)],
        "SA": [m for m in model.denoiser.modules() if isinstance(m, SemanticAlignment)],
    }


def stage_macs(cfg, height: int, width: int) -> dict[str, float]:
    """GMACs per label at ``height x width``, counted on the meta device."""
    from mcd.models import build

    with torch.device("meta"):
        model = build(cfg).eval()
    if not isinstance(model, TwoStage):
        raise ValueError(f"--profile reads the stage labels of the two-stage model (rows A-M, unet); "
                         f"{type(model).__name__} has none")
    x = dummy_batch(model, height, width, "meta")
    with torch.no_grad(), flop_counter_mode() as counter:
        model(x)
    flops = {name: sum(counts.values()) for name, counts in counter.get_flop_counts().items()}
    names: dict[int, list[str]] = {}
    for name, module in model.named_modules(remove_duplicate=False):
        names.setdefault(id(module), []).append(f"{type(model).__name__}.{name}" if name else "Global")
    out = {}
    for label, modules in stage_modules(model).items():
        out[label] = sum(max((flops.get(n, 0) for n in names[id(m)]), default=0) for m in modules) / 2e9
    out["total"] = flops.get("Global", 0) / 2e9
    return out


#: A call that makes fewer page faults than this found the kept heap settled; a reported call that makes more
#: becomes a warm-up and the next is reported, up to :data:`MORE_WARMUPS` times (the heap does not settle
#: for good: row F at 1080p under the profiler ran a call without faults after four, then faulted again).
SETTLED = 1000
MORE_WARMUPS = 4


def minor_faults() -> int:
    """Minor page faults of this process so far (0 where ``resource`` is unavailable)."""
    try:
        import resource
    except ImportError:                                                          # not a Unix
        return 0
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def profile_call(call: Callable[[], object]) -> tuple[dict[str, float], float, int]:
    """Milliseconds per label (inclusive, summed over its calls) and of the whole call, and the page faults
    during it, one profiled call."""
    with profile(activities=[ProfilerActivity.CPU]) as prof:
        faults = minor_faults()
        t0 = time.perf_counter()
        call()
        total = (time.perf_counter() - t0) * 1e3
        faults = minor_faults() - faults
    ms = {label: 0.0 for label, _ in LABELS}
    for event in prof.key_averages():
        if event.key in ms:
            ms[event.key] += event.cpu_time_total / 1e3
    return ms, total, faults


def table(ms: dict[str, float], total: float, gmacs: dict[str, float]) -> list[str]:
    """Markdown table: each label's ms, share of the call, GMACs and GMAC/s; then ``other`` and the call."""
    lines = ["| stage | ms | share | GMACs | GMAC/s |", "|---|---|---|---|---|"]

    def row(name: str, t: float, g: float | None) -> str:
        rate = f"{g / t * 1e3:.3g}" if g and t > 0 else "—"
        return f"| {name} | {t:.1f} | {100 * t / total:.1f}% | {f'{g:.3g}' if g else '—'} | {rate} |"

    for label, depth in LABELS:
        if ms[label] > 0:
            lines.append(row(("&nbsp;&nbsp;" * depth) + label, ms[label], gmacs.get(label)))
    lines.append(row("other", total - sum(ms[s] for s in STAGES), None))
    lines.append(row("**frame**", total, gmacs["total"]))
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m mcd.bench profile", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("overrides", nargs="*", help="Hydra overrides (default: capacity=paper)")
    parser.add_argument("--method", default="F", help="experiment of a two-stage row (A-M, unet)")
    parser.add_argument("--size", default="1080p", help="1080p, 256 or <W>x<H>")
    parser.add_argument("--dtype", choices=("bf16", "fp32"), help="default: bf16 where the CPU has it")
    parser.add_argument("--warmup", type=int, default=2,
                        help=f"profiled calls before the reported one, and up to {MORE_WARMUPS} more while "
                             f"the reported one makes {SETTLED} page faults or more (the kept heap settles)")
    parser.add_argument("--data", help="data profile whose store holds the input frame (default: config's)")
    parser.add_argument("--scene", help="scene of that profile (default: its first test scene)")
    parser.add_argument("--synthetic", action="store_true", help="seeded synthetic inputs, not a store frame")
    parser.add_argument("--out", type=Path, help="also write the table (markdown) here")
    allocator.add_option(parser)
    args = parser.parse_args(argv)
    exit_on_renamed(args.overrides)
    memory = allocator.apply(args.allocator)
    overrides = list(args.overrides)
    if not any(o.startswith("capacity=") for o in overrides):
        overrides.append("capacity=paper")
    try:
        h, w = parse_size(args.size)
    except ValueError as err:
        parser.error(str(err))
    dtype = args.dtype or ("bf16" if cpu_bf16_supported() else "fp32")
    if dtype == "bf16" and not cpu_bf16_supported():
        parser.error("--dtype bf16: this CPU has no native bf16 (avx512_bf16 / amx); use --dtype fp32")
    path = InferencePath(torch.bfloat16 if dtype == "bf16" else None, channels_last=True, compiled=False)
    source = None if args.synthetic else store_frame(args.data, args.scene)
    cfg = compose([f"+experiment={args.method}", *overrides])
    gmacs = stage_macs(cfg, h, w)

    from mcd.models import build

    device = torch.device("cpu")
    model = build(cfg).eval().to(memory_format=torch.channels_last)
    buffers, inputs = frame_buffers(set(model.required_buffers()) - {"ref"}, h, w, source)
    x = model_inputs(model, buffers, device, channels_last=True)
    model.reset()

    def call() -> None:
        with torch.inference_mode(), autocast_to(device, path.dtype):
            model(x)

    for _ in range(args.warmup):         # profiled too: the profiler's own allocations reshape the kept heap
        profile_call(call)
    warmups = args.warmup
    ms, total, faults = profile_call(call)
    while faults >= SETTLED and warmups < args.warmup + MORE_WARMUPS:       # it faulted: that was a warm-up
        warmups += 1
        ms, total, faults = profile_call(call)
    lines = [
        f"# Inference profile: {args.method} at {w}x{h} on the CPU (python -m mcd.bench profile)",
        "",
        f"- Command: `python -m mcd.bench profile {' '.join(argv if argv is not None else [])}`".rstrip(),
        f"- Device: {device_name(device)}; torch {torch.__version__}; path {dtype} channels-last, "
        "inference mode",
        f"- Inputs: {inputs}; {warmups} profiled warm-up call(s), then the profiled call",
        f"- Allocator: {memory} (mcd/allocator.py); page faults during the profiled call: {faults}"
        + ("" if faults < SETTLED else " (the heap had not settled: its first touch of new pages is in these "
                                    "times; raise --warmup)"),
        "",
        *table(ms, total, gmacs),
    ]
    lines.insert(3, f"- Commit: `{short_commit()}`")
    print("\n".join(lines))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text("\n".join(lines) + "\n")

"""``python -m mcd.bench profile``: where a two-stage method's inference time goes, stage by stage, on the CPU
or on CUDA (docs/inference.md "Stage profile").

The method (``--method``, default row F; ``capacity=paper`` unless an override says otherwise) reads one
frame of the store (as ``python -m mcd.bench`` does: a store read, tiled to ``--size``; ``--synthetic``:
seeded synthetic buffers) on ``--device``, along the path ``--dtype`` (``bf16`` autocast where the device
computes bf16 natively, else ``fp32``; channels-last, ``torch.inference_mode``). ``--warmup`` calls, then
``--repeat`` calls read by a :class:`mcd.core.stages.StageClock` interleaved with ``--repeat`` plain calls.

Each stage is a :func:`mcd.core.stages.stage` label of the model: ``input packing``, ``F_s`` (with its
``Ghost conv`` blocks), ``adaptive render``, ``kernel pool`` (``kernel-map head``, ``kernel application``),
``F_d`` (its levels ``L0``..., with ``PP`` and ``SA`` inside), ``output steps``. A stage's time is
*exclusive*: the clock's boundaries are every label's entry and exit (``perf_counter`` on the CPU; CUDA events
on the GPU's stream, read after one synchronize, so launches are not stalled), and the time between two
boundaries goes to the innermost open label; ``other`` is the time inside the call outside every label. The
rows therefore add up to the clock's span, and the table is **refused** (printed under REFUSED and not
written to ``--out``; exit status 3) unless that sum is within ``--tolerance`` (10%) of the frame's wall time
(the clocked call timed from outside, closed by a synchronize on CUDA). The table is one call's: the clocked
call of median wall time, its stages beside its own wall time (the medians of each stage over the calls need
not add up to the median frame on a loaded machine); the median plain frame is printed beside it with its
gap (a gap beyond the tolerance is flagged: the clock changed the frame, or the machine's load changed between
calls). The second table sums each label with what is nested in it (these overlap: ``Ghost conv`` lies in
``F_s`` and in the kernel-map head).

MACs per row are counted the same way (a :class:`mcd.core.stages.FlopClock` over ``FlopCounterMode`` on the
meta device, as :mod:`mcd.models.complexity` counts them), so GMAC/s is each row's own.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import torch
from torch import nn

from mcd.bench.speed import frame_buffers, load_average, parse_size, store_frame
from mcd.config.compose import compose
from mcd.core import allocator
from mcd.core.machine import device_name
from mcd.core.paths import writable_file_arg
from mcd.core.provenance import short_commit
from mcd.core.stages import FlopClock, StageClock
from mcd.lit.precision import autocast_to, cpu_bf16_supported
from mcd.models.complexity import dummy_batch, flop_counter_mode
from mcd.models.latency import model_inputs, sync
from mcd.models.two_stage import TwoStage

#: The name of the time inside the call outside every label.
OTHER = "other"
#: Exit status of a refused table.
REFUSED = 3


def stage_macs(cfg, height: int, width: int) -> dict[str, float]:
    """Exclusive GMACs per label path at ``height x width``, counted on the meta device."""
    from mcd.models import build

    with torch.device("meta"):
        model = build(cfg).eval()
    if not isinstance(model, TwoStage):
        raise ValueError(f"the profile reads the stage labels of the two-stage model (rows A-M, unet); "
                         f"{type(model).__name__} has none")
    x = dummy_batch(model, height, width, "meta")
    with torch.no_grad(), flop_counter_mode() as counter, FlopClock(counter) as clock:
        model(x)
    return {path: flops / 2e9 for path, flops in clock.totals().items()}


def minor_faults() -> int:
    """Minor page faults of this process so far (0 where ``resource`` is unavailable)."""
    try:
        import resource
    except ImportError:                                                          # not a Unix
        return 0
    return resource.getrusage(resource.RUSAGE_SELF).ru_minflt


def timed_call(model: nn.Module, x: dict, device: torch.device, dtype: torch.dtype | None,
               clocked: bool) -> tuple[float, dict[str, float]]:
    """Wall ms of one call (closed by a synchronize on CUDA) and, if ``clocked``, its exclusive ms per label
    path (``""``: outside every label)."""
    sync(device)
    t0 = time.perf_counter()
    with torch.inference_mode(), autocast_to(device, dtype):
        if clocked:
            with StageClock(device) as clock:
                model(x)
        else:
            model(x)
    sync(device)
    wall = (time.perf_counter() - t0) * 1e3
    return wall, (clock.totals() if clocked else {})


def median_call(walls: list[float], runs: list[dict[str, float]]) -> tuple[float, dict[str, float]]:
    """The clocked call of median wall time (the lower middle one for an even count): its wall time and its
    stages, so that the table's rows and its frame come from one call."""
    i = sorted(range(len(walls)), key=walls.__getitem__)[(len(walls) - 1) // 2]
    return walls[i], runs[i]


def table(ms: dict[str, float], frame: float, gmacs: dict[str, float]) -> list[str]:
    """Markdown: each label path's exclusive ms (nested ones indented), share of the frame, GMACs, GMAC/s;
    then ``other``, their sum and the frame."""
    lines = ["| stage (exclusive) | ms | share | GMACs | GMAC/s |", "|---|---|---|---|---|"]

    def row(name: str, t: float, g: float | None) -> str:
        rate = f"{g / t * 1e3:.3g}" if g and t > 0 else "—"
        return f"| {name} | {t:.2f} | {100 * t / frame:.1f}% | {f'{g:.3g}' if g else '—'} | {rate} |"

    for path, t in ms.items():
        if path:
            depth = path.count("/")
            lines.append(row("&nbsp;&nbsp;" * depth + path.rsplit("/", 1)[-1], t, gmacs.get(path)))
    lines.append(row(OTHER, ms.get("", 0.0), gmacs.get("")))
    lines.append(row("**sum of stages**", sum(ms.values()), sum(gmacs.values())))
    lines.append(row("**frame**", frame, sum(gmacs.values())))
    return lines


def inclusive(ms: dict[str, float], gmacs: dict[str, float]) -> list[str]:
    """Markdown: each label name with everything nested in it (rows overlap), ms and GMAC/s."""
    names: list[str] = []
    for path in ms:
        names += [n for n in path.split("/") if n and n not in names]
    lines = ["| label, nested labels included | ms | GMACs | GMAC/s |", "|---|---|---|---|"]
    for name in names:
        t = sum(v for p, v in ms.items() if name in p.split("/"))
        g = sum(v for p, v in gmacs.items() if name in p.split("/"))
        rate = f"{g / t * 1e3:.3g}" if g and t > 0 else "—"
        lines.append(f"| {name} | {t:.2f} | {f'{g:.3g}' if g else '—'} | {rate} |")
    return lines


def refusal(ms: dict[str, float], frame: float, tolerance: float) -> str | None:
    """Why the table cannot stand (its stages do not add up to the frame), or None."""
    total = sum(ms.values())
    if abs(total - frame) > tolerance * frame:
        return (f"the stages sum to {total:.2f} ms, the frame took {frame:.2f} ms "
                f"({100 * (total / frame - 1):+.1f}%, more than {100 * tolerance:.0f}%)")
    return None


def main(argv: list[str] | None = None) -> None:
    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(prog="python -m mcd.bench profile", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("overrides", nargs="*", help="Hydra overrides (default: capacity=paper)")
    parser.add_argument("--method", default="F", help="experiment of a two-stage row (A-M, unet)")
    parser.add_argument("--size", default="1080p", help="1080p, 256 or <W>x<H>")
    parser.add_argument("--device", choices=("cpu", "cuda"), default="cpu")
    parser.add_argument("--dtype", choices=("bf16", "fp32"), help="default: bf16 where the device has it")
    parser.add_argument("--warmup", type=int, default=2, help="calls before the measured ones")
    parser.add_argument("--repeat", type=int, default=3, help="clocked calls, and as many plain ones")
    parser.add_argument("--tolerance", type=float, default=0.10,
                        help="largest relative gap between the stages' sum and the frame before the table "
                             "is refused")
    parser.add_argument("--data", help="data profile whose store holds the input frame (default: config's)")
    parser.add_argument("--scene", help="scene of that profile (default: its first test scene)")
    parser.add_argument("--synthetic", action="store_true", help="seeded synthetic inputs, not a store frame")
    parser.add_argument("--out", type=writable_file_arg("--out"),
                        help="also write the table (markdown) here, unless refused")
    allocator.add_option(parser)
    args = parser.parse_args(argv)
    if args.repeat < 1 or args.warmup < 0:
        parser.error("--repeat needs at least 1 and --warmup at least 0")
    if not 0 <= args.tolerance < float("inf"):  # -1 refused every table, nan none (0: any gap refuses it)
        parser.error(f"--tolerance={args.tolerance}: give a fraction of at least 0 (0.10: 10%)")
    device = torch.device(args.device)
    if device.type == "cuda" and not torch.cuda.is_available():
        parser.error("--device cuda: torch sees no CUDA device here")
    has_bf16 = torch.cuda.is_bf16_supported() if device.type == "cuda" else cpu_bf16_supported()
    dtype = args.dtype or ("bf16" if has_bf16 else "fp32")
    if dtype == "bf16" and not has_bf16:
        parser.error(f"--dtype bf16: this {device.type.upper()} has no native bf16; use --dtype fp32")
    memory = allocator.apply(args.allocator)
    overrides = list(args.overrides)
    if not any(o.startswith("capacity=") for o in overrides):
        overrides.append("capacity=paper")
    try:
        h, w = parse_size(args.size)
    except ValueError as err:
        parser.error(str(err))
    half = torch.bfloat16 if dtype == "bf16" else None
    source = None if args.synthetic else store_frame(args.data, args.scene)
    cfg = compose([f"+experiment={args.method}", *overrides])
    gmacs = stage_macs(cfg, h, w)

    from mcd.models import build

    model = build(cfg).eval().to(device, memory_format=torch.channels_last)
    buffers, inputs = frame_buffers(set(model.required_buffers()) - {"ref"}, h, w, source)
    x = model_inputs(model, buffers, device, channels_last=True)
    model.reset()
    load_start = load_average()
    for _ in range(args.warmup):
        timed_call(model, x, device, half, clocked=True)
        timed_call(model, x, device, half, clocked=False)
    clocked_walls, runs, plain_walls = [], [], []
    faults = minor_faults()
    for _ in range(args.repeat):
        wall, ms = timed_call(model, x, device, half, clocked=True)
        clocked_walls.append(wall)
        runs.append(ms)
        plain_walls.append(timed_call(model, x, device, half, clocked=False)[0])
    faults = minor_faults() - faults
    load_end = load_average()
    (frame, ms), plain = median_call(clocked_walls, runs), statistics.median(plain_walls)
    where = "GPU" if device.type == "cuda" else "CPU"
    why = refusal(ms, frame, args.tolerance)
    gap = frame / plain - 1
    lines = [
        f"# Inference profile: {args.method} at {w}x{h} on the {where} (python -m mcd.bench profile)",
        "",
        f"- Command: `python -m mcd.bench profile {' '.join(argv)}`".rstrip(),
        f"- Commit: `{short_commit()}`",
        f"- Device: {device_name(device)}; torch {torch.__version__}; path {dtype} channels-last, "
        "inference mode",
        f"- Inputs: {inputs}; {args.warmup} warm-up call(s) of each kind, then {args.repeat} clocked and "
        f"{args.repeat} plain calls, interleaved; the table is the clocked call of median wall time",
        f"- Frame: {frame:.2f} ms (wall time of the clocked call); stages (exclusive, "
        f"{'CUDA events' if device.type == 'cuda' else 'perf_counter'}) sum to {sum(ms.values()):.2f} ms; "
        f"plain frame {plain:.2f} ms ({100 * gap:+.1f}%"
        + (", beyond the tolerance: the clock changed the frame, or the load changed between calls)"
           if abs(gap) > args.tolerance else ")"),
        f"- Allocator: {memory} (mcd/core/allocator.py); page faults during the measured calls: {faults}",
        *([f"- Load average (1 min) at the start and the end of the calls: {load_start:.1f}, {load_end:.1f}"]
          if load_start is not None and load_end is not None else []),
        "",
        *table(ms, frame, gmacs),
        "",
        *inclusive(ms, gmacs),
    ]
    if why is not None:
        print(f"REFUSED: {why}; the table below is not a result:\n")
        print("\n".join(lines))
        sys.exit(REFUSED)
    print("\n".join(lines))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text("\n".join(lines) + "\n")

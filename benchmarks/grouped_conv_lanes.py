"""Group convolutions of row F's Fast GhostConv blocks on the CPU, as oneDNN runs them, lane-filled and split
into depth-wise convolutions, and the blocks whose input comes in parts (mcd/models/ghost_conv.py;
docs/inference.md, "Grouped convolutions"), beside a dense 3x3 convolution.

For every Fast GhostConv block of ``F_s`` and the kernel-map head (paper capacity) at its resolution for a
``--width`` x ``--height`` frame: GMAC/s of its 7x7 group convolution as ``conv(x)`` (oneDNN) and through
:func:`mcd.models.ghost_conv.lane_filled_conv` with the ``S`` that :func:`lane_stride` picks, bf16 autocast
and channels-last (the bench's fastest CPU path); for the blocks where :func:`mcd.models.ghost_conv.splits`
holds, the group conv followed by the block's point-wise conv both ways (lane-filled then ``point``, and
:func:`split_depthwise_point`); and for the two blocks whose input is a concatenation (the full-resolution
decoder block of ``F_s``: upsampled features and skip; the kernel-map head's first block: finest features,
``g``, ``i`` and the broadcast kernel descriptor), group + point-wise conv on the concatenation (built in the
timed call) against :func:`mcd.models.ghost_conv.group_then_point` on the parts. Times are the best of
``--reps`` calls in thread CPU time (``time.thread_time``), which a machine shared with other jobs disturbs
far less than wall time; run it with ``OMP_NUM_THREADS=1``.

    OMP_NUM_THREADS=1 python benchmarks/grouped_conv_lanes.py --width 960 --height 544
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import torch
import torch.nn.functional as F

from mcd.bench import compose_cfg, device_name
from mcd.models import build
from mcd.models.ghost_conv import (
    group_then_point,
    lane_filled_conv,
    lane_stride,
    split_depthwise_point,
    splits,
)
from mcd.models.inputs import broadcast

CL = torch.channels_last


def best_cpu_ms(call: Callable[[], object], reps: int) -> float:
    """Best thread CPU time of ``reps`` calls (after one warm-up), in ms."""
    call()
    best = float("inf")
    for _ in range(reps):
        t0 = time.thread_time()
        call()
        best = min(best, time.thread_time() - t0)
    return best * 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--width", type=int, default=960)
    parser.add_argument("--height", type=int, default=544)
    parser.add_argument("--reps", type=int, default=3)
    args = parser.parse_args()
    model = build(compose_cfg("F", ["model=paper"])).eval().to(memory_format=torch.channels_last)
    unet = model.sampler.unet
    levels = [(f"F_s encoder {j}", unet.encoder[j], 2 ** j) for j in range(len(unet.encoder))]
    levels += [(f"F_s decoder {j}", unet.decoder[j], 2 ** (len(unet.decoder) - 1 - j))
               for j in range(len(unet.decoder))]
    levels.append(("kernel-map head", model.sampler.head.blocks, 1))
    print(f"{device_name(torch.device('cpu'))}, {args.width}x{args.height}, bf16 channels-last, "
          f"best of {args.reps} (thread CPU time)")
    print("| block | group conv | S | oneDNN GMAC/s | lane-filled GMAC/s | speed-up "
          "| group + point: lane-filled ms | split depth-wise ms | speed-up |")
    print("|---|---|---|---|---|---|---|---|---|")
    with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16):
        for name, blocks, scale in levels:
            for block in blocks:
                conv = block.group
                h, w = args.height // scale, args.width // scale
                x = torch.rand(1, conv.in_channels, h, w).bfloat16().contiguous(memory_format=CL)
                cout, cin_g, kh, kw = conv.weight.shape
                s = lane_stride(cin_g, cout // conv.groups, kw)
                gmacs = h * w * cout * cin_g * kh * kw / 1e9
                plain = best_cpu_ms(lambda conv=conv, x=x: conv(x), args.reps)
                filled = best_cpu_ms(lambda conv=conv, x=x, s=s: lane_filled_conv(conv, x, s), args.reps)
                split = "| — | — | — |"
                if splits(conv.in_channels, cout // conv.groups):
                    p = block.point
                    lanes = best_cpu_ms(lambda c=conv, x=x, s=s, p=p: p(lane_filled_conv(c, x, s)), args.reps)
                    parts = best_cpu_ms(lambda c=conv, x=x, p=p: split_depthwise_point(c, p, x), args.reps)
                    split = f"| {lanes:.1f} | {parts:.1f} | {lanes / parts:.2f}x |"
                print(f"| {name} | {conv.in_channels}->{cout}, {conv.groups} groups | {s} | "
                      f"{gmacs / plain * 1e3:.1f} | {gmacs / filled * 1e3:.1f} | {plain / filled:.2f}x "
                      f"{split}")
        print("\n| block in parts | group + point on the concatenation ms | on the parts ms | speed-up |")
        print("|---|---|---|---|")
        h, w = args.height, args.width
        decoder = unet.decoder[-1][0]
        skip = unet.widths[0]
        head = model.sampler.head.blocks[0]
        desc = torch.randn(1, model.sampler.pool.describe.out_channels)
        for name, block, widths, constant in (
                (f"F_s decoder, full resolution, {decoder.group.in_channels - skip} upsampled + {skip} skip",
                 decoder, (decoder.group.in_channels - skip, skip), None),
                ("kernel-map head, finest 16 + g 7 + i 3 + descriptor 16", head, (skip, 7, 3), desc)):
            parts = [torch.rand(1, c, h, w).bfloat16().contiguous(memory_format=CL) for c in widths]
            whole = parts if constant is None else [*parts, broadcast(constant, parts[0])]
            g, p = block.group, block.point
            cat = best_cpu_ms(lambda g=g, p=p, whole=whole:
                              group_then_point(g, p.weight, p.bias, [torch.cat(whole, 1)]), args.reps)
            split = best_cpu_ms(lambda g=g, p=p, parts=parts, c=constant:
                                group_then_point(g, p.weight, p.bias, parts, c), args.reps)
            print(f"| {name} | {cat:.1f} | {split:.1f} | {cat / split:.2f}x |")
        print()
        for cin, cout in ((16, 16), (32, 32), (64, 64)):
            x = torch.rand(1, cin, args.height, args.width).bfloat16().contiguous(memory_format=CL)
            weight = torch.rand(cout, cin, 3, 3).bfloat16().contiguous(memory_format=CL)
            gmacs = args.height * args.width * cin * cout * 9 / 1e9
            ms = best_cpu_ms(lambda x=x, weight=weight: F.conv2d(x, weight, padding=1), args.reps)
            print(f"| dense 3x3 reference | {cin}->{cout} | — | {gmacs / ms * 1e3:.1f} | — | — |")


if __name__ == "__main__":
    main()

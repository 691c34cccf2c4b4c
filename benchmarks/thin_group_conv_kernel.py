"""Experiment, not used by mcd: a direct convolution kernel for thin 7x7 groups (C++ with AVX-512 BF16,
benchmarks/thin_group_conv_kernel.cpp, built here with ``torch.utils.cpp_extension``) against oneDNN, for the
group convolutions of row F (docs/inference.md, "A direct kernel for thin groups").

The kernel reads channel pairs interleaved in a planar layout (``[B, G, C/2, H, W, 2]``, zero-padded) and
writes fp32 planes; the channels-last bf16 tensors of the model need a copy in and a copy out. For each shape:
the error against the fp32 conv of the same bf16 values, and GMAC/s of oneDNN's grouped conv (bf16,
channels-last), of the kernel alone, and of the kernel with the two copies (channels-last bf16 in and out).
Best of ``--reps`` calls in thread CPU time; run with ``OMP_NUM_THREADS=1``. Needs g++ and a CPU with
AVX512-BF16; the first run compiles the extension (a minute or two).

    OMP_NUM_THREADS=1 python benchmarks/thin_group_conv_kernel.py --width 960 --height 544
"""

from __future__ import annotations

import argparse
from pathlib import Path

import torch
import torch.nn.functional as F
from grouped_conv_lanes import best_cpu_ms  # this folder (run as a script)
from torch import Tensor
from torch.utils.cpp_extension import load

from mcd.bench import device_name

#: (in, out, groups, resolution divisor): the group convolutions of row F's ``F_s`` and kernel-map head.
SHAPES = ((16, 8, 4, 1), (12, 8, 4, 1), (64, 8, 4, 1), (48, 24, 4, 2), (144, 24, 4, 2), (42, 20, 2, 1),
          (40, 20, 4, 1), (96, 48, 4, 4))
PAD_ROWS = 8                           # the kernel's last row block may read up to this many rows past H


def layout(x: Tensor, weight: Tensor, groups: int) -> tuple[Tensor, Tensor, int]:
    """The kernel's input and weight layouts (channel pairs interleaved, zero-padded) and the padded width."""
    b, _, h, w = x.shape
    cout, cin_g, k, _ = weight.shape
    co, pairs, pad = cout // groups, (cin_g + 1) // 2, k // 2
    wr = -(-w // 16) * 16
    xp = F.pad(x, (pad, pad + wr - w, pad, pad + PAD_ROWS))
    hp, wp = xp.shape[-2:]
    xg = F.pad(xp.reshape(b, groups, cin_g, hp, wp), (0, 0, 0, 0, 0, cin_g % 2))
    wg = F.pad(weight.reshape(groups, co, cin_g, k, k), (0, 0, 0, 0, 0, cin_g % 2))
    x2 = xg.view(b, groups, pairs, 2, hp, wp).permute(0, 1, 2, 4, 5, 3).contiguous()
    w2 = wg.reshape(groups, co, pairs, 2, k, k).permute(0, 1, 2, 4, 5, 3).contiguous()
    return x2, w2, wr


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--width", type=int, default=960)
    parser.add_argument("--height", type=int, default=544)
    parser.add_argument("--reps", type=int, default=3)
    args = parser.parse_args()
    ext = load("mcd_thin_group_conv_experiment", [str(Path(__file__).with_suffix(".cpp"))],
               extra_cflags=["-O3", "-mavx512f", "-mavx512bw", "-mavx512vl", "-mavx512bf16"])
    cl = torch.channels_last
    torch.manual_seed(0)
    print(f"{device_name(torch.device('cpu'))}, {args.width}x{args.height}, best of {args.reps} "
          f"(thread CPU time)")
    print("| group conv | resolution | max error / max | oneDNN GMAC/s | kernel GMAC/s "
          "| kernel + copies GMAC/s |")
    print("|---|---|---|---|---|---|")
    for cin, cout, groups, scale in SHAPES:
        h, w = args.height // scale, args.width // scale
        x = torch.randn(1, cin, h, w).bfloat16().contiguous(memory_format=cl)
        weight = (torch.randn(cout, cin // groups, 7, 7) * 0.1).bfloat16().contiguous(memory_format=cl)
        bias = torch.randn(cout).bfloat16()

        def kernel(x: Tensor = x, weight: Tensor = weight, bias: Tensor = bias, groups: int = groups,
                   h: int = h, w: int = w) -> Tensor:
            x2, w2, wr = layout(x, weight, groups)
            y = ext.thin_group_conv(x2, w2, h, wr).view(1, -1, h, wr)[..., :w]
            return (y + bias.float().view(1, -1, 1, 1)).to(torch.bfloat16, memory_format=cl)

        ref = F.conv2d(x.float(), weight.float(), bias.float(), padding=3, groups=groups)
        err = float((kernel().float() - ref).abs().max() / ref.abs().max())
        x2, w2, wr = layout(x, weight, groups)
        gmacs = h * w * cout * (cin // groups) * 49 / 1e9
        onednn = best_cpu_ms(lambda x=x, weight=weight, bias=bias, groups=groups:
                             F.conv2d(x, weight, bias, padding=3, groups=groups), args.reps)
        alone = best_cpu_ms(lambda x2=x2, w2=w2, h=h, wr=wr: ext.thin_group_conv(x2, w2, h, wr), args.reps)
        whole = best_cpu_ms(kernel, args.reps)
        print(f"| {cin}->{cout}, {groups} groups | {w}x{h} | {err:.1e} | {gmacs / onednn * 1e3:.1f} "
              f"| {gmacs / alone * 1e3:.1f} | {gmacs / whole * 1e3:.1f} |")


if __name__ == "__main__":
    main()

"""Row F at 1080p on the CPU with its blocks handed their inputs in parts, against the same model with every
input concatenated first (the behaviour before; docs/inference.md, "Inputs in parts").

One process, one model (``model=paper``, seeded weights), seeded random 1920x1080 inputs,
``torch.inference_mode`` with bf16 autocast and channels-last (the bench's fastest CPU path; ``--dtype fp32``:
fp32 channels-last). The variants
alternate call by call, each timed in thread CPU time (which a machine shared with other jobs disturbs far
less than wall time):

- ``concatenated``: :func:`mcd.models.blocks.on_parts` replaced by a concatenation of the parts and of the
  broadcast kernel descriptor, and :func:`mcd.models.inputs.cat_channels` by ``torch.cat`` (so the inputs of
  ``F_s`` and ``F_d`` are NCHW, as ``torch.cat`` leaves them);
- ``parts``: the code as it is;
- ``parts, no split``: as ``parts`` with :data:`mcd.models.ghost_conv.SPLIT_MAX_IN` = 0 (no split depth-wise
  convolutions).

    OMP_NUM_THREADS=1 python benchmarks/inputs_in_parts_ab.py --reps 3
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Sequence

import torch
from torch import Tensor, nn

import mcd.models.ghost_conv as ghost_conv
import mcd.models.kernel_pool as kernel_pool
import mcd.models.two_stage as two_stage
import mcd.models.unet as unet
from mcd.bench import compose_cfg, device_name
from mcd.models import build
from mcd.models.blocks import on_parts
from mcd.models.inputs import cat_channels

VARIANTS = ("concatenated", "parts", "parts, no split")
SPLIT_MAX_IN = ghost_conv.SPLIT_MAX_IN


def concatenated(block: nn.Module, parts: Sequence[Tensor], constant: Tensor | None = None) -> Tensor:
    """The block on the concatenation of the parts and of the broadcast constant."""
    whole = list(parts)
    if constant is not None:
        like = parts[0]
        whole.append(constant[:, :, None, None].expand(like.shape[0], -1, *like.shape[-2:]).to(like.dtype))
    return block(torch.cat(whole, 1))


def plain_cat(tensors: Sequence[Tensor]) -> Tensor:
    return torch.cat(list(tensors), 1)


def use(variant: str) -> None:
    parts, cat = (concatenated, plain_cat) if variant == "concatenated" else (on_parts, cat_channels)
    unet.on_parts = kernel_pool.on_parts = parts
    two_stage.cat_channels = ghost_conv.cat_channels = cat
    ghost_conv.SPLIT_MAX_IN = 0 if variant == "parts, no split" else SPLIT_MAX_IN


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--reps", type=int, default=3)
    parser.add_argument("--width", type=int, default=1920)
    parser.add_argument("--height", type=int, default=1080)
    parser.add_argument("--dtype", choices=("bf16", "fp32"), default="bf16")
    args = parser.parse_args()
    cl = torch.channels_last
    torch.manual_seed(0)
    model = build(compose_cfg("F", ["model=paper"])).eval().to(memory_format=cl)
    gen = torch.Generator().manual_seed(1)
    x: dict[str, Tensor | None] = {
        name: (torch.rand(1, 1 if name == "depth" else 3, args.height, args.width, generator=gen)
               * (20 if name.startswith("c") else 1)).contiguous(memory_format=cl)
        for name in sorted(model.required_buffers())}
    x["ref"] = None
    times: dict[str, list[float]] = {v: [] for v in VARIANTS}
    print(f"{device_name(torch.device('cpu'))}, {torch.get_num_threads()} thread(s), row F, "
          f"{args.width}x{args.height}, {args.dtype} channels-last, thread CPU s per call")
    with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16, enabled=args.dtype == "bf16"):
        outputs = {}
        for v in VARIANTS:                                                    # warm-up, and the outputs
            use(v)
            outputs[v] = model(x)["output"].float()
        for v in VARIANTS[1:]:
            diff = float((outputs[v] - outputs[VARIANTS[0]]).abs().max())
            print(f"max |{v} - {VARIANTS[0]}| = {diff:.2e} (mean |output| "
                  f"{float(outputs[VARIANTS[0]].abs().mean()):.3f})")
        for _ in range(args.reps):
            for v in VARIANTS:
                use(v)
                t0 = time.thread_time()
                model(x)
                times[v].append(time.thread_time() - t0)
    use("parts")
    for v in VARIANTS:
        ts = sorted(times[v])
        print(f"| {v} | {' '.join(f'{t:.2f}' for t in times[v])} | median {ts[len(ts) // 2]:.2f} |")


if __name__ == "__main__":
    main()

"""Row F's forward as ``python -m mcd.denoise`` runs it (fp32, NCHW, CPU), under ``torch.no_grad`` against
``torch.inference_mode``, under which the CPU fast paths of mcd/models/ghost_conv.py apply (docs/denoise.md
"Speed", docs/inference.md). Not a test: prints figures.

    MCD_SCENES_DIR=<scenes> python benchmarks/denoise_inference_mode.py [--width 960 --height 544 --reps 3]

Input: frame 0 of the small profile's first test scene through the store's reader, tiled to the size; the
bundled checkpoint F-cpu-small. Prints ms per call for each mode and rep, then how far apart the two outputs
are with the same seed.
"""

from __future__ import annotations

import argparse
import time

import torch

from mcd import bench
from mcd.denoise.weights import load


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--width", type=int, default=960)
    parser.add_argument("--height", type=int, default=544)
    parser.add_argument("--reps", type=int, default=3)
    args = parser.parse_args()
    model = load("F-cpu-small").model.eval()
    names = set(model.required_buffers()) - {"ref"}
    bufs, where = bench.frame_buffers(names, args.height, args.width, bench.store_frame("small", None))
    x = bench.model_inputs(model, bufs, torch.device("cpu"), channels_last=False)
    print(f"{where}, {args.width}x{args.height}, {torch.get_num_threads()} threads")

    def once() -> torch.Tensor:
        torch.manual_seed(1)
        model.reset()
        return model(x)["output"]

    outputs = {}
    for rep in range(args.reps):
        for mode, ctx in (("no_grad", torch.no_grad), ("inference_mode", torch.inference_mode)):
            with ctx():
                start = time.perf_counter()
                outputs[mode] = once()
                print(f"rep {rep} {mode}: {(time.perf_counter() - start) * 1000:.0f} ms")
    diff = (outputs["no_grad"] - outputs["inference_mode"]).abs()
    print(f"outputs apart: max {diff.max().item():.3g}, mean {diff.mean().item():.3g} "
          f"(mean |output| {outputs['no_grad'].abs().mean().item():.3g})")


if __name__ == "__main__":
    main()

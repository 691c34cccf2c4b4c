"""How much of its input the sampling network ``F_s`` still carries, block by block (docs/method.md
"Initialisation"): for a checkpoint (a bundled name, a run directory or a ``.ckpt``) or a freshly built model
(Hydra overrides, e.g. ``+experiment=F capacity=cpu method.init=he``), each block's spatial standard
deviation (per channel over the frame, averaged over channels), its share of positive outputs, and whether
it is constant (a spatial deviation below 1e-6: the block carries nothing of the input, and no
gradient passes it), then the sampling logits' standard deviation. Inputs: seeded uniform frames in the
sampler's ranges (colour and grey channels in [0, 1], normals in [-1, 1]).

    PYTHONPATH=. python tools/sampler_signal.py --checkpoint F-cpu-bundle
    PYTHONPATH=. python tools/sampler_signal.py +experiment=F capacity=cpu method.init=torch
"""

from __future__ import annotations

import argparse
import sys

import torch


def block_table(model: torch.nn.Module, size: int, seed: int) -> tuple[list[tuple[str, float, float]], float]:
    """``([(block, spatial std, positive share)], logits std)`` of ``model.sampler`` on seeded inputs."""
    from mcd.models.blocks import ConvReLU
    from mcd.models.ghost_conv import FastGhostConv

    rows: list[tuple[str, float, float]] = []
    hooks = [mod.register_forward_hook(lambda m, i, o, n=name: rows.append(
                 (n, float(o.float().std(dim=(0, 2, 3)).mean()), float((o > 0).float().mean()))))
             for name, mod in model.sampler.unet.named_modules() if isinstance(mod, FastGhostConv | ConvReLU)]
    x = torch.rand(2, 12, size, size, generator=torch.Generator().manual_seed(seed))
    x[:, 3:6] = 2 * x[:, 3:6] - 1
    with torch.no_grad():
        logits = model.sampler(x)["logits"]
    for h in hooks:
        h.remove()
    return rows, float(logits.std())


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--checkpoint", help="a bundled name, a run directory or a .ckpt file")
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("overrides", nargs="*", help="Hydra overrides of a freshly built model")
    args = parser.parse_args(argv)
    if args.checkpoint:
        from mcd.denoise import weights

        model, what = weights.load(args.checkpoint).model, f"--checkpoint {args.checkpoint}"
    else:
        from mcd.config.compose import compose
        from mcd.models.registry import build

        torch.manual_seed(args.seed)
        model, what = build(compose(args.overrides)), "built with " + " ".join(args.overrides or ["defaults"])
    if getattr(model, "sampler", None) is None:
        print(f"error: {what}: the model has no sampling network (method.AS off)", file=sys.stderr)
        return 2
    rows, logits_std = block_table(model, args.size, args.seed)
    print(f"# F_s, {what}; {args.size}x{args.size} seeded inputs (seed {args.seed})")
    print("| block | spatial std | positive share | constant |")
    print("|---|---|---|---|")
    for name, std, live in rows:
        print(f"| {name} | {std:.2e} | {live:.3f} | {'yes' if std < 1e-6 else ''} |")
    print(f"logits: spatial std {logits_std:.2e}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

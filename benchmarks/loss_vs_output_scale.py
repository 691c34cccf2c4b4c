"""How a trained run's own loss varies with the brightness of its output (docs/baselines.md, "DASR's loss").

Loads a finished run of ``python -m mcd.run`` (its checkpoint and ``resolved_config.yaml``), runs its
validation clips and prints, averaged over them: the loss terms of the output as tested (the output steps of
:mod:`mcd.models.output_steps` on), of the output with the mean match's gain unclamped, and of the network's
raw output (no output steps) scaled by each ``--scales`` factor, with the output's per-channel mean over the
reference's. A loss whose minimum lies at an output darker than the reference pulls the network dark.

    OMP_NUM_THREADS=1 python benchmarks/loss_vs_output_scale.py multirun/baselines/small/dasr_spp4
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch
from omegaconf import OmegaConf

from mcd.bench import device_name


def probe(run_dir: Path, scales: list[float]) -> None:
    import mcd.models.mean_match as mean_match
    from mcd.data import Store
    from mcd.data.buffers import run_buffers
    from mcd.data.datamodule import MCDDataModule
    from mcd.denoise.weights import load
    from mcd.lit.module import DenoiseModule, clip_buffers
    from mcd.losses import build_loss

    metrics = run_dir / "metrics.json"
    if not metrics.is_file():
        raise SystemExit(f"{metrics}: not a finished run (no metrics.json); give a finished run directory")
    cfg = OmegaConf.load(run_dir / "resolved_config.yaml")
    model = load(json.loads(metrics.read_text())["checkpoint"]).model.eval()
    store = Store.from_cfg(cfg, overrides=[])
    buffers = run_buffers(model.required_buffers(), cfg.budget)
    datamodule = MCDDataModule(cfg, store, buffers, model.window)
    datamodule.setup("fit")
    loss = build_loss(cfg)
    module = DenoiseModule(cfg, model, loss)
    print(f"run {run_dir} (loss {cfg.loss.name}), {device_name(torch.device('cpu'))}")
    clamp = mean_match.GAIN_MAX
    # (name, the mean match's gain limit, output steps on, scales of the output the loss is computed on)
    variants = (("as tested", clamp, True, [1.0]), ("gain unclamped", 1e9, True, [1.0]),
                ("raw", clamp, False, scales))
    for name, gain_max, steps, factors in variants:
        hooks = dict(model._forward_hooks)  # the output steps' hook (mcd.models.output_steps)
        if not steps:
            model._forward_hooks.clear()
        mean_match.GAIN_MAX = gain_max
        sums = dict.fromkeys(factors, 0.0)
        ratios = []
        try:
            with torch.no_grad():
                for batch in datamodule.val_dataloader():
                    pred = module.run_clip(batch, with_ref=False)
                    ref = clip_buffers(batch)["ref"][:, -pred.shape[1]:]
                    for f in factors:
                        sums[f] += float(loss(pred * f, ref)["loss"])
                    ratios.append(pred[:, -1].mean((0, 2, 3)) / ref[:, -1].mean((0, 2, 3)).clamp_min(1e-12))
        finally:
            model._forward_hooks.update(hooks)
            mean_match.GAIN_MAX = clamp
        means = [round(float(r), 3) for r in torch.stack(ratios).mean(0)]
        print(f"\n{name}: output mean / reference mean per channel (x1) {means}")
        for f, total in sums.items():
            print(f"  loss x{f:g}: {total / len(ratios):.4f}")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir", type=Path, help="a finished run directory of python -m mcd.run")
    ap.add_argument("--scales", type=float, nargs="+", default=[0.5, 1, 2, 4, 8, 12])
    args = ap.parse_args(argv)
    probe(args.run_dir, args.scales)


if __name__ == "__main__":
    main()

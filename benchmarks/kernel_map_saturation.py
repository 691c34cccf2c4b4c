"""Whether the kernel pool is used: the kernel map's identity share and kernel index over training, for
variants of the kernel-pool options (paper Sec. 4.1; docs/kernel_pool.md). Not a test: prints figures.

    python benchmarks/kernel_map_saturation.py [--experiments C,F] [--steps 300] [--every 100]
        [--variant NAME=OVERRIDE,OVERRIDE ...] [--table docs/kernel_pool_variants.md]
        [overrides ...]

Each variant (default: :data:`VARIANTS`) trains each KP row (default C and F) from the same seed on the
rendered data of the configured profile (default tiny) with the run's loss, Adam at ``train.lr``
cosine-annealed over ``--steps`` steps, batch ``train.batch_size``, running the clip frames the loss needs
(mcd.lit.module). Every ``--every`` steps and at the end it prints, on the validation clips (last frame,
whole val crops):
- ``z[0]``, ``z[1]``: the kernel-map head's pre-``tanh`` output (mean ± std over pixels, after
  ``head_output``'s scaling); a large ``z[1]`` means ``tanh`` saturates and the pool gets no gradient;
- ``identity``: mean identity weight ``(h[1] + 1) / 2`` (1 = ``i_bar == i``, the pool unused), ``>.975``: the
  share of pixels above 0.975;
- ``index std``: the spread of the kernel index ``h[0]`` across each frame's pixels (0 = one kernel
  everywhere), ``max tap``: the mean largest tap of the adjusted pool kernels (0.04 = a uniform 5x5 box);
- L1 (log1p range) to the reference of ``i_bar``, ``i`` and the output, and the validation PSNR (dB, the test
  metric of mcd.metrics) of the output.
``--table`` writes the final row of every (variant, row) as a Markdown table with the command and machine.
"""

from __future__ import annotations

import argparse
import math
import shlex
import sys
import time
from pathlib import Path

import numpy as np
import torch
from hydra import compose, initialize_config_dir

from mcd.data import MCDDataModule, StoreBuilder
from mcd.data.buffers import run_buffers
from mcd.lit.module import DenoiseModule, clip_buffers, cosine_factor
from mcd.losses import build_loss
from mcd.metrics import psnr
from mcd.models import build
from mcd.models.kernel_pool import identity_weight
from mcd.run import device_name, git_commit

CONF = str(Path(__file__).resolve().parent.parent / "conf")

#: name -> Hydra overrides of method.kp (docs/kernel_pool.md).
VARIANTS = {
    "reads i, tanh (before)": ["method.kp.denoiser_reads_adaptive=true", "method.kp.head_output=tanh"],
    "tanh (paper text)": ["method.kp.head_output=tanh"],
    "tempered z/8": ["method.kp.head_output=tempered", "method.kp.temperature=8"],
    "rms": ["method.kp.head_output=rms"],
    "rms, pool x5": ["method.kp.head_output=rms", "method.kp.pool_init_scale=5"],
    "rms_centred (default)": ["method.kp.head_output=rms_centred"],
}
COLUMNS = ("variant", "row", "steps", "z0", "z1", "identity", "id>.975", "index std", "max tap", "L1 i_bar",
           "L1 i", "L1 out", "val PSNR", "s")


def l1_log(x: torch.Tensor, ref: torch.Tensor) -> float:
    return (torch.log1p(x.detach().clamp_min(0)) - torch.log1p(ref.clamp_min(0))).abs().mean().item()


@torch.no_grad()
def evaluate(model: torch.nn.Module, lit: DenoiseModule, dm: MCDDataModule, z: dict[str, torch.Tensor]
             ) -> dict[str, float]:
    """The figures of the module docstring on the validation clips (last frame of each)."""
    model.eval()
    rows: list[dict[str, float]] = []
    for batch in dm.val_dataloader():
        buffers = clip_buffers(batch)
        model.reset()
        steps = buffers["ref"].shape[1]
        first = lit.clip_plan(steps)[0]
        for t in range(first, steps):
            out = model(lit._frame_input(buffers, t, with_ref=False))
        ref = buffers["ref"][:, -1]
        h, zz = out["kernel_map"].float(), model.sampler.head.scale(z["z"].float())
        pool = model.sampler.pool
        coarsest = model.sampler(model.sampler_input(lit._frame_input(buffers, steps - 1, False)))["coarsest"]
        taps = pool.normalised(pool.adjust(coarsest))
        rows.append({
            "z0": zz[:, 0].mean().item(), "z0s": zz[:, 0].std().item(),
            "z1": zz[:, 1].mean().item(), "z1s": zz[:, 1].std().item(),
            "identity": identity_weight(h).mean().item(),
            "id>.975": (identity_weight(h) > 0.975).float().mean().item(),
            "index std": h[:, 0].flatten(1).std(1).mean().item(),
            "max tap": taps.max(-1).values.mean().item(),
            "L1 i_bar": l1_log(out["initial"], ref), "L1 i": l1_log(out["adaptive"], ref),
            "L1 out": l1_log(out["output"], ref),
            "val PSNR": float(np.mean([psnr(o.permute(1, 2, 0).numpy(), r.permute(1, 2, 0).numpy())
                                       for o, r in zip(out["output"].float(), ref.float(), strict=True)])),
        })
    model.train()
    return {k: float(np.mean([r[k] for r in rows])) for k in rows[0]}


def train_variant(experiment: str, overrides: list[str], steps: int, every: int, seed: int,
                  label: str) -> dict[str, float]:
    with initialize_config_dir(config_dir=CONF, version_base="1.3"):
        cfg = compose("config", overrides=[f"+experiment={experiment}", *overrides])
    if not cfg.method.get("KP"):
        raise SystemExit(f"+experiment={experiment} has no kernel pool (method.KP=false): pick C-J")
    torch.manual_seed(seed)
    model = build(cfg)
    buffers = run_buffers(model.required_buffers(), cfg.budget)
    store = StoreBuilder.from_cfg(cfg)
    store.ensure(buffers)
    dm = MCDDataModule(cfg, store, buffers, model.window)
    dm.setup("fit")
    lit = DenoiseModule(cfg, model, build_loss(cfg))
    lr, lr_min = float(cfg.train.lr), float(cfg.train.lr_min)
    opt = torch.optim.Adam(model.parameters(), lr=lr)
    z: dict[str, torch.Tensor] = {}
    model.sampler.head.out.register_forward_hook(lambda m, i, o: z.__setitem__("z", o.detach()))
    print(f"\n{label} | {experiment} on {cfg.data.name}, lr {lr}, batch {cfg.train.batch_size}", flush=True)
    print("step  z[0]         z[1]          identity  >.975  index std  max tap  L1 i_bar  L1 i    L1 out  "
          "val PSNR  s", flush=True)
    step, t0, last = 0, time.perf_counter(), {}
    while step < steps:
        for batch in dm.train_dataloader():
            for group in opt.param_groups:
                group["lr"] = lr * cosine_factor(step / steps, lr, lr_min)
            pred = lit.run_clip(batch, with_ref=True)
            value = lit.loss_fn(pred, clip_buffers(batch)["ref"][:, -pred.shape[1]:])["loss"]
            opt.zero_grad()
            value.backward()
            opt.step()
            step += 1
            if step % every == 0 or step == steps:
                last = {**evaluate(model, lit, dm, z), "steps": step, "s": time.perf_counter() - t0}
                print(f"{step:4d}  {last['z0']:5.2f}±{last['z0s']:5.2f}  "
                      f"{last['z1']:6.2f}±{last['z1s']:5.2f}  "
                      f"{last['identity']:8.3f}  {last['id>.975']:5.3f}  {last['index std']:9.3f}  "
                      f"{last['max tap']:7.3f}  {last['L1 i_bar']:8.4f}  {last['L1 i']:.4f}  "
                      f"{last['L1 out']:.4f}  {last['val PSNR']:8.2f}  {last['s']:.0f}", flush=True)
            if step >= steps:
                break
    return last


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--experiments", default="C,F")
    ap.add_argument("--steps", type=int, default=300)
    ap.add_argument("--every", type=int, default=100)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--variant", action="append", default=[],
                    help="NAME=OVERRIDE[,OVERRIDE...] (repeatable); default: the VARIANTS table")
    ap.add_argument("--table", type=Path, help="write the final figures as a Markdown table here")
    ap.add_argument("overrides", nargs="*", help="Hydra overrides for every variant, e.g. data=small")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    commit = git_commit()  # the code the runs use, recorded before they start
    variants = dict(VARIANTS)
    if args.variant:
        variants = {v.split("=", 1)[0]: v.split("=", 1)[1].split(",") for v in args.variant}
    results = []
    for name, extra in variants.items():
        for experiment in args.experiments.split(","):
            last = train_variant(experiment, [*args.overrides, *extra], args.steps, args.every, args.seed,
                                 name)
            results.append({"variant": name, "row": experiment, **last})
    if args.table:
        command = "python " + " ".join(shlex.quote(a) for a in sys.argv)
        fmt = {"z0": "{:.2f}", "z1": "{:.2f}", "identity": "{:.3f}", "id>.975": "{:.3f}",
               "index std": "{:.3f}",
               "max tap": "{:.3f}", "L1 i_bar": "{:.4f}", "L1 i": "{:.4f}", "L1 out": "{:.4f}",
               "val PSNR": "{:.2f}", "s": "{:.0f}", "steps": "{}"}
        lines = [f"`{command}`", "",
                 f"commit {commit['commit'][:10]}{' (dirty)' if commit['dirty'] else ''}, "
                 f"{device_name(torch.device('cpu'))}, "
                 f"seed {args.seed}, "
                 f"overrides {args.overrides or 'none'}; variants: "
                 + "; ".join(f"**{k}** = `{' '.join(v)}`" for k, v in variants.items()), "",
                 "| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
        for r in results:
            cells = [str(r[c]) if c in ("variant", "row") else fmt[c].format(r[c]) if not (
                isinstance(r[c], float) and math.isnan(r[c])) else "-" for c in COLUMNS]
            lines.append("| " + " | ".join(cells) + " |")
        args.table.parent.mkdir(parents=True, exist_ok=True)
        args.table.write_text("\n".join(lines) + "\n")
        print(f"wrote {args.table}")


if __name__ == "__main__":
    main()

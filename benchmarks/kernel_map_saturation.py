"""How the kernel map's identity channel evolves in training (paper Sec. 3.1; not a test: prints figures).

    python benchmarks/kernel_map_saturation.py [--experiment C] [--steps 200] [--every 25] [overrides ...]

Trains one KP row (default C) on the rendered data of the configured profile (default tiny) with the run's
loss and Adam at ``train.lr``, one optimiser step per training batch, and prints every ``--every`` steps: the
kernel-map head's pre-``tanh`` outputs ``z`` (mean ± std per channel), the share of pixels whose identity
weight ``(h[1] + 1) / 2`` is above 0.975, the largest tap of the adjusted pool kernels (0.04 = a uniform 5x5
box) and the L1 error (log1p range, last frame of the batch) of ``i_bar``, ``i`` and the output against the
reference. ``i_bar == i`` (L1 equal) with ``z[1]`` large means the pool is bypassed: ``tanh`` saturates and
the pool stops receiving gradient. Single-threaded by default (``--threads``), so it can share a busy machine.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch
from hydra import compose, initialize_config_dir

from mcd.data import MCDDataModule, Store
from mcd.lit import build_loss
from mcd.models import build
from mcd.models.kernel_pool import identity_weight

CONF = str(Path(__file__).resolve().parent.parent / "conf")


def l1_log(x: torch.Tensor, ref: torch.Tensor) -> float:
    return (torch.log1p(x.detach().clamp_min(0)) - torch.log1p(ref.clamp_min(0))).abs().mean().item()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--experiment", default="C")
    ap.add_argument("--steps", type=int, default=200)
    ap.add_argument("--every", type=int, default=25)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("overrides", nargs="*", help="Hydra overrides, e.g. data=small train.lr=3e-4")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    with initialize_config_dir(config_dir=CONF, version_base="1.3"):
        cfg = compose("config", overrides=[f"+experiment={args.experiment}", *args.overrides])
    if not cfg.method.get("KP"):
        raise SystemExit(f"+experiment={args.experiment} has no kernel pool (method.KP=false): pick C-J")
    torch.manual_seed(args.seed)
    model = build(cfg)
    buffers = set(model.required_buffers()) | {"ref", f"c{int(cfg.budget)}"}
    store = Store.from_cfg(cfg)
    store.ensure(buffers)
    dm = MCDDataModule(cfg, store, buffers, model.window)
    dm.setup("fit")
    loss = build_loss(cfg)
    opt = torch.optim.Adam(model.parameters(), lr=float(cfg.train.lr))
    pre_tanh: dict[str, torch.Tensor] = {}
    model.sampler.head.out.register_forward_hook(lambda m, i, o: pre_tanh.__setitem__("z", o.detach()))
    pool = model.sampler.pool
    print(f"{args.experiment} on {cfg.data.name}, lr {cfg.train.lr}, batch {cfg.train.batch_size}")
    print("step  loss    z[0]          z[1]          id>.975  pool max tap  L1 i_bar  L1 i    L1 out  s")
    step, t0 = 0, time.perf_counter()
    while step < args.steps:
        for batch in dm.train_dataloader():
            clip = {k: v for k, v in batch.items() if isinstance(v, torch.Tensor) and v.ndim == 5}
            model.reset()
            outs = [model({k: v[:, t] for k, v in clip.items()}) for t in range(clip["ref"].shape[1])]
            value = loss(torch.stack([o["output"] for o in outs], 1), clip["ref"])["loss"]
            opt.zero_grad()
            value.backward()
            opt.step()
            step += 1
            if step % args.every == 0:
                z, last, ref = pre_tanh["z"], outs[-1], clip["ref"][:, -1]
                identity = (identity_weight(last["kernel_map"]) > 0.975).float().mean()
                with torch.no_grad():
                    coarsest = model.sampler(model.sampler_input({k: v[:, -1] for k, v in clip.items()}))
                    tap = pool.normalised(pool.adjust(coarsest["coarsest"]))  # this input's adjusted pool
                print(f"{step:4d}  {value.item():.4f}  {z[:, 0].mean():6.2f}±{z[:, 0].std():5.2f}  "
                      f"{z[:, 1].mean():6.2f}±{z[:, 1].std():5.2f}  {identity:7.3f}  "
                      f"{tap.max(-1).values.mean():12.3f}  {l1_log(last['initial'], ref):8.4f}  "
                      f"{l1_log(last['adaptive'], ref):.4f}  {l1_log(last['output'], ref):.4f}  "
                      f"{time.perf_counter() - t0:.0f}", flush=True)
            if step >= args.steps:
                break


if __name__ == "__main__":
    main()

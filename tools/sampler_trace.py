"""When and how the sampling network ``F_s`` goes constant during training (docs/method.md "Initialisation",
docs/benchmark.md "Sampling-map health"): trains one configuration as ``python -m mcd.run`` does (the same
build: data, model, module, trainer) and, every ``--every`` optimiser steps, writes one CSV row of
``F_s``'s state:

- ``logits_std``: the sampling logits' spatial standard deviation on seeded inputs (tools/sampler_signal.py's
  inputs), and ``map_spread`` / ``map_min`` / ``map_max``: the integer map those logits give at the run's
  budget (mcd.sampling.normalise; a spread of 0 samples uniformly);
- ``first_constant``: the first block of ``F_s``'s U-Net whose output is constant over the frame (a spatial
  deviation below 1e-6; empty while none is) and ``dead_units``: the units of that U-Net's blocks that are 0
  on every pixel (a ReLU unit negative everywhere passes no gradient);
- the gradient norms of that step: ``grad_logits_head`` (the 1x1 convolution that makes the logits: only
  the adaptive render's DASR gradient reaches it), ``grad_sampler`` (all of ``F_s``: the DASR gradient and,
  with KP, the kernel-map head's), ``grad_denoiser`` (``F_d``), and the step's learning rate.

    PYTHONPATH=. python tools/sampler_trace.py --out trace.csv --every 25 \
        +experiment=F data=tiny train=plateau train.max_steps=1000 seed=2 paths.data_dir=<data>

The run directory is a scratch folder (``--run-dir``, default a temporary one); the run is not tested.
"""

from __future__ import annotations

import argparse
import csv
import sys
import tempfile
from pathlib import Path

import torch


def _blocks(sampler: torch.nn.Module) -> list[tuple[str, torch.nn.Module]]:
    from mcd.models.blocks import ConvReLU
    from mcd.models.ghost_conv import FastGhostConv

    return [(n, m) for n, m in sampler.unet.named_modules() if isinstance(m, FastGhostConv | ConvReLU)]


@torch.no_grad()
def sampler_state(model: torch.nn.Module, budget: float, size: int = 64, seed: int = 0) -> dict[str, object]:
    """``F_s``'s logits, map and blocks on seeded inputs (see the module docstring)."""
    from mcd.core.metrics import map_spread
    from mcd.sampling.normalise import normalise_map, shares

    outputs: list[tuple[str, torch.Tensor]] = []
    hooks = [m.register_forward_hook(lambda mod, i, o, n=name: outputs.append((n, o.detach().float())))
             for name, m in _blocks(model.sampler)]
    x = torch.rand(2, 12, size, size, generator=torch.Generator().manual_seed(seed))
    x[:, 3:6] = 2 * x[:, 3:6] - 1
    was_training = model.sampler.training
    model.sampler.eval()
    try:
        logits = model.sampler(x)["logits"].float()
    finally:
        model.sampler.train(was_training)
        for h in hooks:
            h.remove()
    m = normalise_map(shares(logits), budget)
    constant = [n for n, o in outputs if float(o.std(dim=(0, 2, 3)).mean()) < 1e-6]
    dead = sum(int((o.amax(dim=(0, 2, 3)) <= 0).sum()) for _, o in outputs)
    units = sum(o.shape[1] for _, o in outputs)
    return {"logits_std": float(logits.std()), "map_spread": map_spread(m[0, 0].numpy()),
            "map_min": float(m.min()), "map_max": float(m.max()),
            "first_constant": constant[0] if constant else "", "dead_units": f"{dead}/{units}"}


def _norm(params: list[torch.nn.Parameter]) -> float:
    grads = [p.grad for p in params if p.grad is not None]
    return float(torch.nn.utils.get_total_norm(grads)) if grads else 0.0


def trace_callback(path: Path, every: int, budget: float):
    """A Lightning callback writing one row of :func:`sampler_state` and the step's gradient norms to
    ``path`` every ``every`` optimiser steps (and at step 0)."""
    from lightning.pytorch.callbacks import Callback

    class Trace(Callback):
        def __init__(self) -> None:
            self.fields: list[str] | None = None

        def _write(self, row: dict[str, object]) -> None:
            new = self.fields is None
            self.fields = self.fields or list(row)
            with path.open("a", newline="") as f:
                w = csv.DictWriter(f, self.fields)
                if new:
                    w.writeheader()
                w.writerow(row)

        def on_before_optimizer_step(self, trainer, pl_module, optimizer) -> None:
            step = trainer.global_step
            if step % every:
                return
            model = pl_module.model
            row: dict[str, object] = {"step": step, "lr": optimizer.param_groups[0]["lr"]}
            row |= {"grad_logits_head": _norm(list(model.sampler.unet.head.parameters())),
                    "grad_sampler": _norm(list(model.sampler.parameters())),
                    "grad_denoiser": _norm(list(model.denoiser.parameters()))}
            row |= sampler_state(model, budget)
            self._write(row)
            print(" ".join(f"{k}={v:.3g}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()),
                  flush=True)

    return Trace()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", type=Path, required=True, help="the CSV to write (replaced)")
    parser.add_argument("--every", type=int, default=25, help="optimiser steps between rows")
    parser.add_argument("--run-dir", type=Path, help="scratch run directory (default: a temporary one)")
    parser.add_argument("overrides", nargs="*", help="Hydra overrides of the run, as for python -m mcd.run")
    args = parser.parse_args(argv)
    from mcd.config.compose import compose
    from mcd.run import build, fit

    cfg = compose(args.overrides)
    if not cfg.method.get("AS", False):
        print("error: the configuration has no sampling network (method.AS off)", file=sys.stderr)
        return 2
    args.out.unlink(missing_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        job = build(cfg, args.run_dir or Path(tmp) / "run", {"data": str(cfg.data.name)})
        job.trainer.callbacks.append(trace_callback(args.out, args.every, float(cfg.budget)))
        fit(job)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

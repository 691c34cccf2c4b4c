"""A/B of the training step's fast paths (notes/f_speed.md "The training step"): one optimiser step of a
method as the scaling study trains it (conf/sweep/scaling.yaml: ``train=cpu``, ``capacity=cpu``, the
profile's ``train.batch_size`` clips of ``data.clip_len`` frames at ``data.train_crop``), with the paths and
without them, in one process, the two alternating step by step on the same batches.

The step is :class:`mcd.lit.module.DenoiseModule`'s: ``run_clip`` (the finiteness check of the clip, the
model reset and run frame by frame, the frames before the last ``train.grad_frames`` without gradient) and the
configured loss under ``trainer.precision`` as ``auto`` resolves it here (bf16 autocast on a CPU with native
bf16), the weights channels-last where ``train.channels_last``, backward, the gradients' norm (logged each
step by the module) and an Adam step. Lightning's own loop, logging and validation are not in it.

"Without" is the code before the paths:

- ``kernel_backward``: :func:`mcd.models.kernel_pool.apply_pixel_kernels` through autograd's backward of its
  multiply-adds instead of :class:`mcd.models.kernel_pool.PixelKernels`;
- ``finite_check``: :func:`mcd.lit.module.check_finite` as ``torch.isfinite(value).all()``;
- ``pad_backward``: :func:`mcd.models.cpu_fast.replicate.replicate_pad` as ``F.pad`` with autograd's backward
  (the gradient handed to ATen's kernel in the layout it arrives in);
- ``upsample_backward``: :func:`mcd.models.cpu_fast.upsample.upsample_bilinear` as ``F.interpolate`` with
  autograd's backward;
- ``advance``: the clip frames whose output the loss does not read run the whole forward instead of
  :meth:`mcd.models.two_stage.TwoStage.advance` (``F_d``'s encoder only).

Batches: the profile's training clips read from its store (``--data``, ``paths.data_dir`` by ``--set``; read
only, checksums not verified), or ``--synthetic`` clips (:func:`mcd.data.synthetic.synthetic_frame`). Prints
each step's ms, the medians, the median of the pairs' ratios and the gradients' largest difference between
the two sides (0: the same numbers). Run with ``OMP_NUM_THREADS=1``.

    OMP_NUM_THREADS=1 PYTHONPATH=. python tools/train_step_ab.py --methods F,ntasad --data small \\
        --set paths.data_dir=/path/to/data --repeat 8
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from types import SimpleNamespace

import torch
from torch import Tensor

from mcd.config.compose import compose
from mcd.core.machine import device_name
from mcd.core.provenance import short_commit
from mcd.lit import module as lit_module
from mcd.lit.precision import resolve
from mcd.models import kernel_pool
from mcd.models.cpu_fast import replicate, upsample
from mcd.models.two_stage import TwoStage

PATHS = ("kernel_backward", "finite_check", "pad_backward", "upsample_backward", "advance")


def isfinite_check(buffers: dict[str, Tensor], batch: dict[str, object]) -> None:
    """:func:`mcd.lit.module.check_finite` as it was: ``torch.isfinite(value).all()`` per buffer."""
    for name, value in buffers.items():
        if not torch.isfinite(value).all():
            raise ValueError(f"non-finite values in buffer {name!r}")


@contextmanager
def without(paths: list[str]) -> Iterator[None]:
    """The code before ``paths`` (module docstring)."""
    saved = lit_module.check_finite, replicate.fast_paths, upsample.fast_paths
    advance = TwoStage.advance
    off = SimpleNamespace(enabled=lambda: False)  # a module's own switch, and that one only
    if "kernel_backward" in paths:  # autograd.Function's own apply comes back when this one is deleted
        kernel_pool.PixelKernels.apply = kernel_pool.pixel_kernel_passes  # type: ignore[method-assign]
    if "finite_check" in paths:
        lit_module.check_finite = isfinite_check
    if "pad_backward" in paths:
        replicate.fast_paths = off  # type: ignore[assignment]
    if "upsample_backward" in paths:
        upsample.fast_paths = off  # type: ignore[assignment]
    if "advance" in paths:
        TwoStage.advance = lambda self, x: self(x)  # type: ignore[method-assign]
    try:
        yield
    finally:
        if "apply" in vars(kernel_pool.PixelKernels):
            del kernel_pool.PixelKernels.apply
        lit_module.check_finite, replicate.fast_paths, upsample.fast_paths = saved
        TwoStage.advance = advance  # type: ignore[method-assign]


def batches(cfg, model, n: int, synthetic: bool) -> list[dict[str, object]]:  # noqa: ANN001
    """``n`` training batches of ``cfg``'s profile for ``model`` (module docstring)."""
    from mcd.data.buffers import run_buffers

    names = run_buffers(model.required_buffers(), cfg.budget)
    if synthetic:
        from mcd.data.synthetic import synthetic_frame

        crop = int(cfg.data.train_crop)
        lead = (int(cfg.train.batch_size), int(cfg.data.clip_len))
        return [synthetic_frame(names, crop, crop, lead=lead, seed=i) for i in range(n)]
    from mcd.data.datamodule import MCDDataModule
    from mcd.data.store import StoreReader

    dm = MCDDataModule(cfg, StoreReader.from_cfg(cfg, overrides=[]), names, model.window)
    dm.setup()
    out: list[dict[str, object]] = []
    while len(out) < n:
        out += list(dm.train_dataloader())
    return out[:n]


def step_call(experiment: str, data: str, extra: list[str], n: int, synthetic: bool
              ) -> tuple[Callable[[dict[str, object]], dict[str, Tensor]], list[dict[str, object]], str]:
    """One training step of ``experiment`` (module docstring) as a function of a batch that returns the
    gradients; the batches; the precision."""
    from mcd.lit.module import DenoiseModule
    from mcd.losses import build_loss
    from mcd.models import build

    cfg = compose([f"+experiment={experiment}", f"data={data}", "data.verify_checksums=never", *extra])
    torch.manual_seed(0)
    model = build(cfg).train()
    if cfg.train.get("channels_last"):
        model.to(memory_format=torch.channels_last)
    module = DenoiseModule(cfg, model, build_loss(cfg))
    precision = resolve(str(cfg.trainer.get("precision", "auto")), "cpu")
    half = torch.bfloat16 if precision.startswith("bf16") else None
    opt = torch.optim.Adam(model.parameters(), lr=float(cfg.train.lr))
    start = {k: v.detach().clone() for k, v in model.state_dict().items()}

    def call(batch: dict[str, object]) -> dict[str, Tensor]:
        model.load_state_dict(start)  # every step from the same weights: the two sides' gradients compare
        with torch.autocast("cpu", dtype=half or torch.float32, enabled=half is not None):
            pred = module.run_clip(batch, with_ref=True)
            loss = module.loss_fn(pred, batch["ref"][:, -pred.shape[1]:])["loss"]
        opt.zero_grad(set_to_none=True)
        loss.backward()
        grads = {k: p.grad.detach().clone() for k, p in model.named_parameters() if p.grad is not None}
        torch.nn.utils.get_total_norm(list(grads.values()))
        opt.step()
        return grads

    return call, batches(cfg, model, n, synthetic), precision


def ab(name: str, call: Callable[[dict[str, object]], dict[str, Tensor]], data: list[dict[str, object]],
       paths: list[str], warmup: int) -> None:
    """Alternate ``call`` with and without ``paths`` over ``data``; print the medians and ratios."""
    times: dict[str, list[float]] = {"with": [], "without": []}
    worst = 0.0

    def timed(which: str, batch: dict[str, object]) -> tuple[float, dict[str, Tensor]]:
        with ExitStack() as stack:
            if which == "without":
                stack.enter_context(without(paths))
            t0 = time.perf_counter()
            grads = call(batch)
        return (time.perf_counter() - t0) * 1e3, grads

    for batch in data[:warmup]:
        timed("without", batch)
        timed("with", batch)
    for i, batch in enumerate(data[warmup:]):
        order = ("without", "with") if i % 2 == 0 else ("with", "without")
        got = {}
        for which in order:
            ms, got[which] = timed(which, batch)
            times[which].append(ms)
        for k, g in got["with"].items():
            ref = got["without"][k].float()
            worst = max(worst, float((g.float() - ref).abs().max() / ref.abs().max().clamp_min(1e-30)))
    med = {k: statistics.median(v) for k, v in times.items()}
    pairs = [a / b for a, b in zip(times["without"], times["with"], strict=True)]
    for k, v in times.items():
        print(f"{name} {k:7s} ms: " + " ".join(f"{t:.0f}" for t in v) + f"  median {med[k]:.1f}")
    print(f"{name}: without / with = {med['without'] / med['with']:.3f}x (medians), "
          f"{statistics.median(pairs):.3f}x (median of the pairs' ratios); gradients' largest difference "
          f"{worst:.3g} of each tensor's largest value")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--methods", default="F", help="experiments, comma-separated (+experiment=<name>)")
    ap.add_argument("--data", default="small", help="data profile (the scaling study's: tiny, small, medium)")
    ap.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                    help="a config override, e.g. paths.data_dir=/data (repeatable)")
    ap.add_argument("--paths", default=",".join(PATHS), help=f"comma-separated, of {', '.join(PATHS)}")
    ap.add_argument("--synthetic", action="store_true", help="synthetic clips instead of the store's")
    ap.add_argument("--warmup", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=6, help="timed steps per side")
    args = ap.parse_args()
    paths = args.paths.split(",")
    unknown = sorted(set(paths) - set(PATHS))
    if unknown:
        ap.error(f"--paths: unknown {unknown}; choose of {', '.join(PATHS)}")
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    print(f"commit {short_commit()}; {device_name(torch.device('cpu'))}; torch {torch.__version__}; "
          f"{torch.get_num_threads()} thread(s); load average {load}")
    for method in args.methods.split(","):
        call, data, precision = step_call(method, args.data, args.set, args.warmup + args.repeat,
                                          args.synthetic)
        ab(f"{method} {args.data} ({precision})", call, data, paths, args.warmup)
    print(f"load average at the end {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()

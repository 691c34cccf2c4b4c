"""The LightningModule that trains, validates and tests every method (docs/method.md, "Training protocol").

- Training / validation: a batch holds clips ``[B, T, C, H, W]``; the model is ``reset()`` at the clip start
  and run frame by frame so that temporal models carry their state across the clip. Only the frames the loss
  reads are computed (docs/training.md, "Throughput"): a loss with ``frames_needed = k`` (the paper's: 2, the
  last two for ``L_t``) gets the last ``k`` outputs; a model without temporal state (``temporal_state``
  false) runs only those ``k`` frames, a temporal one runs the whole clip and, with ``train.grad_frames = n``,
  the frames before the last ``n`` without gradient (truncated backpropagation through time). ``ref``
  reaches the model in training only (DASR's gradient).
- ``train.channels_last``: the model's weights in channels-last (NHWC) memory format during ``fit``, so
  convolutions run in oneDNN's (and cuDNN's) preferred layout; the same numbers up to summation order.
- ``train.compile``: ``torch.compile`` (inductor) of the model in place during ``fit`` (off by default: not
  faster on this project's CPU, docs/training.md "Throughput").
- Validation logs ``val/loss`` and ``val/psnr``, ``val/ssim`` of the last frame of each clip (the test
  metrics of ``mcd.core.metrics``), each averaged over the validation clips of all processes (``sync_dist``),
  so that under DDP every rank picks the same best checkpoint: the one with the highest ``val/psnr``. The
  training loss and its terms are logged as their mean over the processes too (:func:`mean_over_processes`,
  one all-reduce of the detached terms per step), so ``logs/metrics.csv`` and ``curve.csv`` show the loss of
  the whole effective batch, not rank 0's share. ``train/grad_norm`` is the gradients' total L2 norm before
  any clipping (``train.grad_clip``), logged each step beside the loss: where a loss jumps, it shows whether a
  large update came first (docs/training.md "Budgets").
- The learning rate follows a cosine from ``train.lr`` to ``train.lr_min`` over the training budget
  (:func:`cosine_factor`; the budget's progress is ``DenoiseModule.progress``), after a linear warm-up over
  the first ``train.warmup_steps`` optimiser steps (:func:`warmup_factor`; 0: none, the paper's schedule;
  docs/training.md "Budgets").
- Test: whole frames, one current frame per batch, in sequence order; ``reset()`` where ``batch["reset"]``
  is set, so state is carried across a whole test sequence. ``test_step`` returns the frame's outputs, its
  reference and the noisy uniform input at the same budget (``c{budget}``); the test recorder
  (``mcd.lit.test_recorder``) turns them into metrics, samples and ``frames.csv``.
- Models with a frame window ``(past, future) != (0, 0)`` get ``[B, past+1+future, C, H, W]`` per step, edge
  frames repeated at clip ends (as the test datamodule does at sequence ends).
"""

from __future__ import annotations

import math
import time

import lightning as L
import torch
import torch.distributed as dist
from omegaconf import DictConfig, OmegaConf
from torch import Tensor, nn

from mcd.config.preflight import check_warmup
from mcd.core.metrics import frame_metrics
from mcd.data.buffers import uniform_buffer
from mcd.lit.test_recorder import hwc


def clip_buffers(batch: dict[str, object]) -> dict[str, Tensor]:
    """The image buffers of a batch: its ``[B, T, C, H, W]`` tensors (not ``scene``, ``frame``, ``reset``)."""
    return {k: v for k, v in batch.items() if isinstance(v, Tensor) and v.ndim == 5}


def check_finite(buffers: dict[str, Tensor], batch: dict[str, object]) -> None:
    """Raise if a non-finite value reached the module: the data loader must sanitise NaN/Inf at load.

    A buffer is finite when the largest of its absolute values is (a maximum keeps NaN): one reduction
    instead of ``torch.isfinite(value).all()``'s four passes and three full-size temporaries, a tenth of its
    time (notes/f_speed.md "The training step")."""
    for name, value in buffers.items():
        if value.numel() and not bool(value.abs().amax().isfinite()):
            raise ValueError(f"non-finite values in buffer {name!r} of scenes {batch.get('scene')} frames "
                             f"{batch.get('frame')}: the datamodule must sanitise NaN/Inf at load")


def mean_over_processes(values: Tensor) -> Tensor:
    """``values`` averaged over the processes of the default process group (one all-reduce); as they are
    outside distributed training. Every process must call it the same number of times."""
    if not (dist.is_available() and dist.is_initialized()) or dist.get_world_size() < 2:
        return values
    total = values.detach().clone()
    dist.all_reduce(total, op=dist.ReduceOp.SUM)
    return total / dist.get_world_size()


def cosine_factor(progress: float, lr: float, lr_min: float) -> float:
    """Multiplier of ``lr`` at ``progress`` (0..1) of the budget: a cosine from ``lr`` down to ``lr_min``."""
    p = min(max(progress, 0.0), 1.0)
    floor = lr_min / lr if lr > 0 else 0.0
    return floor + (1.0 - floor) * 0.5 * (1.0 + math.cos(math.pi * p))


def warmup_factor(step: int, warmup_steps: int) -> float:
    """Multiplier of the learning rate at optimiser step ``step`` (0-based): ``(step + 1) / warmup_steps``
    during the first ``warmup_steps`` steps, then 1 (and always 1 for ``warmup_steps`` 0)."""
    return 1.0 if step >= warmup_steps else (step + 1) / warmup_steps


class DenoiseModule(L.LightningModule):
    """Trains ``model`` with ``loss`` (``mcd.losses``) and tests it on whole sequences."""

    def __init__(self, cfg: DictConfig, model: nn.Module, loss: nn.Module) -> None:
        super().__init__()
        self.cfg = cfg
        self.model = model
        # The loss (with its frozen VGG) is not part of the checkpointed state: kept outside the module tree.
        self.__dict__["loss_fn"] = loss
        self.budget = int(cfg.budget)
        grad_frames = cfg.train.get("grad_frames")
        self.grad_frames = None if grad_frames is None else int(grad_frames)
        if self.grad_frames is not None and self.grad_frames < 1:
            raise ValueError(f"train.grad_frames={grad_frames}: give the number of last clip frames that "
                             "get gradient (>= 1), or null for all")
        #: The cosine schedule's budget: seconds (``train.max_minutes``) and steps (``train.max_steps``).
        minutes, steps = cfg.train.get("max_minutes"), cfg.train.get("max_steps")
        self.max_seconds = 60 * float(minutes) if minutes else None
        self.max_steps = int(steps) if steps else None
        self._fit_started: float | None = None
        self._total_steps = math.inf
        self.save_hyperparameters({"cfg": OmegaConf.to_container(cfg, resolve=True)})

    # -- frame-by-frame execution -------------------------------------------------------------------------
    def _frame_input(self, buffers: dict[str, Tensor], t: int, with_ref: bool) -> dict[str, Tensor | None]:
        past, future = self.model.window
        if (past, future) == (0, 0):
            x: dict[str, Tensor | None] = {k: v[:, t] for k, v in buffers.items()}
        else:
            last = next(iter(buffers.values())).shape[1] - 1
            idx = [min(max(i, 0), last) for i in range(t - past, t + future + 1)]
            x = {k: v[:, idx] for k, v in buffers.items()}
        if not with_ref:
            x["ref"] = None
        return x

    def clip_plan(self, steps: int) -> tuple[int, int, int]:
        """``(first frame run, first frame with gradient, first frame returned)`` for a clip of ``steps``.

        The loss reads its last ``frames_needed`` outputs (all when it does not say); a model without
        temporal state need not run the frames before those; a temporal model runs the whole clip, the frames
        before the last ``train.grad_frames`` without gradient.
        """
        needed = getattr(self.loss_fn, "frames_needed", None)
        returned = steps - min(int(needed), steps) if needed else 0
        if not getattr(self.model, "temporal_state", True):
            return returned, returned, returned
        grad = 0 if self.grad_frames is None else max(steps - max(self.grad_frames, steps - returned), 0)
        return 0, grad, returned

    def run_clip(self, batch: dict[str, object], with_ref: bool) -> Tensor:
        """Outputs ``[B, T', 3, H, W]`` of a clip's last ``T'`` frames (:meth:`clip_plan`), the model reset at
        the clip start and stepped frame by frame; a frame before those whose output is not read goes through
        the model's ``advance(x)`` where it has one (the frame's state only)."""
        buffers = clip_buffers(batch)
        check_finite(buffers, batch)
        self.model.reset()
        first, grad_from, returned = self.clip_plan(buffers["ref"].shape[1])
        outputs = []
        advance = getattr(self.model, "advance", None)
        for t in range(first, buffers["ref"].shape[1]):
            with torch.set_grad_enabled(torch.is_grad_enabled() and t >= grad_from):
                x = self._frame_input(buffers, t, with_ref)
                if t < returned and callable(advance):  # the state only (e.g. TwoStage.advance)
                    advance(x)
                    continue
                y = self.model(x)["output"]
            if t >= returned:
                outputs.append(y)
        return torch.stack(outputs, dim=1)

    def _loss(self, batch: dict[str, object], stage: str, with_ref: bool) -> tuple[Tensor, Tensor]:
        pred = self.run_clip(batch, with_ref)
        terms = self.loss_fn(pred, clip_buffers(batch)["ref"][:, -pred.shape[1]:])
        size = pred.shape[0]
        logged = dict(terms)
        if stage == "train":  # mean over the ranks (validation averages with sync_dist at epoch end)
            names = list(terms)
            mean = mean_over_processes(torch.stack([terms[k].detach().float() for k in names]))
            logged = dict(zip(names, mean.unbind(0), strict=True))
        for name, value in logged.items():
            self.log(f"{stage}/{name}", value, prog_bar=name == "loss", on_step=stage == "train",
                     on_epoch=True, batch_size=size, sync_dist=stage == "val")
        return terms["loss"], pred

    # -- Lightning hooks ----------------------------------------------------------------------------------
    def on_fit_start(self) -> None:
        self.loss_fn.to(self.device)
        if self.cfg.train.get("channels_last"):  # NHWC weights: oneDNN's fast layout (docs/training.md)
            self.model.to(memory_format=torch.channels_last)
        if self.cfg.train.get("compile"):  # in place: the state dict keeps its keys (docs/training.md)
            self.model.compile()

    def on_train_start(self) -> None:
        self._fit_started = time.perf_counter()

    def progress(self, step: int) -> float:
        """How much of the training budget ``step`` has used (0..1): the larger of the step share
        (``max_steps`` or the epochs' steps) and the wall-clock share (``max_seconds``)."""
        total = min(self._total_steps, float(self.max_steps or math.inf))
        shares = [step / total] if math.isfinite(total) and total > 0 else []
        if self.max_seconds and self._fit_started is not None:
            shares.append((time.perf_counter() - self._fit_started) / self.max_seconds)
        return max(shares, default=0.0)

    def training_step(self, batch: dict[str, object], batch_idx: int) -> Tensor:
        loss, _ = self._loss(batch, "train", with_ref=True)
        if not torch.isfinite(loss):
            raise FloatingPointError(f"non-finite training loss at step {self.global_step} (scenes "
                                     f"{batch.get('scene')}, frames {batch.get('frame')}); lower train.lr "
                                     "or use trainer.precision=32-true")
        return loss

    def on_before_optimizer_step(self, optimizer: torch.optim.Optimizer) -> None:
        """Log the gradients' total norm (Lightning calls this after unscaling and before clipping)."""
        grads = [p.grad for p in self.model.parameters() if p.grad is not None]
        if grads:
            norm = torch.nn.utils.get_total_norm(grads).float()
            self.log("train/grad_norm", mean_over_processes(norm[None])[0], on_step=True, on_epoch=False)

    def validation_step(self, batch: dict[str, object], batch_idx: int) -> Tensor:
        loss, pred = self._loss(batch, "val", with_ref=False)
        ref = clip_buffers(batch)["ref"][:, -1]
        for b in range(pred.shape[0]):
            scores = frame_metrics(hwc(pred[b, -1]), hwc(ref[b]))
            for name in ("psnr", "ssim"):
                self.log(f"val/{name}", scores[name], on_epoch=True, batch_size=1, sync_dist=True)
        return loss

    def configure_optimizers(self) -> dict[str, object]:
        train = self.cfg.train
        lr, lr_min = float(train.lr), float(train.lr_min)
        opt = torch.optim.Adam(self.model.parameters(), lr=lr, weight_decay=float(train.weight_decay))
        self._total_steps = float(self.trainer.estimated_stepping_batches)
        warmup = check_warmup(self.cfg)
        sched = torch.optim.lr_scheduler.LambdaLR(
            opt, lambda step: warmup_factor(step, warmup) * cosine_factor(self.progress(step), lr, lr_min))
        return {"optimizer": opt, "lr_scheduler": {"scheduler": sched, "interval": "step"}}

    def test_step(self, batch: dict[str, object], batch_idx: int) -> dict[str, object]:
        buffers = clip_buffers(batch)
        check_finite(buffers, batch)
        if buffers["ref"].shape[0] != 1:
            raise ValueError(f"test batches must hold one frame (B=1), got B={buffers['ref'].shape[0]}")
        reset = bool(batch["reset"][0])
        if reset:
            self.model.reset()
        past = self.model.window[0]
        out = self.model(self._frame_input(buffers, past, with_ref=False))
        noisy = buffers[uniform_buffer(self.budget)][0, past]
        return {"scene": str(batch["scene"][0]), "frame": int(batch["frame"][0, past]), "reset": reset,
                "outputs": out, "ref": buffers["ref"][0, past], "noisy": noisy}

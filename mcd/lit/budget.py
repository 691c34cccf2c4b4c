"""Training budgets, learning curves and why training stopped (docs/training.md, "Budgets").

A run trains until the first of ``train.max_steps`` optimiser steps, ``train.max_minutes`` of wall clock,
``train.epochs`` epochs, or a plateau of the validation PSNR (``train.patience`` validations without a gain of
``train.min_delta`` dB) is reached; ``null`` turns a limit off, and at least one of the first three must be
set. Validation runs every ``train.val_every_steps`` optimiser steps (else every ``train.val_every`` epochs).
The cosine learning-rate schedule spans the budget (``mcd.lit.module.DenoiseModule.progress``); :func:`finish`
validates where the budget ended when the last validation came before it (then rewriting ``last.ckpt``).
:class:`LearningCurve` appends validation PSNR/SSIM/loss against step and seconds to ``curve.csv``.
"""

from __future__ import annotations

import csv
import logging
import math
import time
from pathlib import Path

import lightning as L
import torch
from lightning.pytorch.callbacks import Callback, EarlyStopping, ModelCheckpoint, Timer
from omegaconf import DictConfig, OmegaConf

from mcd.core.config_rules import checked
from mcd.lit import precision
from mcd.lit.csv_log import ResumableCSVLogger, drop_rows_after

log = logging.getLogger(__name__)

#: Columns of ``curve.csv``: one row per validation.
CURVE_COLUMNS = ("step", "epoch", "seconds", "lr", "train_loss", "val_loss", "val_psnr", "val_ssim")


def _limit(train: DictConfig, key: str) -> float | None:
    """``train.<key>`` as a number, or None (no limit); its range is the rule of mcd/core/config_rules.py."""
    value = checked(f"train.{key}", train.get(key))
    return None if value is None else float(value)


#: Lightning Trainer arguments that ``train.*`` keys set (:func:`trainer_limits`); ``trainer.*`` must not.
FROM_TRAIN = {"max_epochs": "epochs", "max_time": "max_minutes", "val_check_interval": "val_every_steps",
              "check_val_every_n_epoch": "val_every", "limit_train_batches": "limit_train_batches",
              "gradient_clip_val": "grad_clip", "max_steps": "max_steps"}


def trainer_limits(train: DictConfig) -> dict[str, object]:
    """Lightning Trainer arguments for the epoch and time budget, the validation cadence, the batches per
    epoch and the gradient clipping of ``train.*`` (the step budget is :class:`StepLimit`, in
    :func:`callbacks`)."""
    epochs, steps, minutes = (_limit(train, k) for k in ("epochs", "max_steps", "max_minutes"))
    if epochs is None and steps is None and minutes is None:
        raise ValueError("no training budget: set train.max_steps, train.max_minutes or train.epochs")
    every = train.get("val_every_steps")
    kwargs: dict[str, object] = {"max_epochs": int(epochs) if epochs is not None else -1,
                                 "limit_train_batches": train.get("limit_train_batches", 1.0),
                                 "gradient_clip_val": train.get("grad_clip")}
    if minutes is not None:
        kwargs["max_time"] = {"seconds": minutes * 60}
    if every:
        kwargs.update(val_check_interval=int(every), check_val_every_n_epoch=None)
    else:
        kwargs.update(check_val_every_n_epoch=int(train.get("val_every", 1)))
    return kwargs


def trainer_kwargs(cfg: DictConfig) -> dict[str, object]:
    """Every Lightning Trainer argument a run takes from its config: ``cfg.trainer`` with ``precision``
    resolved (``auto``: mcd.lit.precision) and the limits of :func:`trainer_limits`. On the CPU it also
    flushes denormal floats to zero (slow on x86, meaningless for images). ``use_distributed_sampler`` is
    always off: under DDP the datamodule shards training and validation itself and tests every frame on
    rank 0 (mcd/data/datamodule.py), which Lightning's sampler would split between the ranks."""
    kwargs = OmegaConf.to_container(cfg.trainer, resolve=True)
    owned = sorted(k for k in kwargs if k in FROM_TRAIN)
    if owned:
        key, train_key = owned[0], FROM_TRAIN[owned[0]]
        raise ValueError(f"trainer.{key} is set by train.{train_key} (one key per setting, "
                         f"docs/architecture.md \"Config\"): set train.{train_key} and remove trainer.{key}")
    if kwargs.get("use_distributed_sampler"):
        raise ValueError("trainer.use_distributed_sampler=true: the datamodule distributes the data itself "
                         "(training and validation sharded, the test on rank 0: mcd/data/datamodule.py); "
                         "remove the key")
    kwargs["use_distributed_sampler"] = False
    accelerator = str(kwargs.get("accelerator", "auto"))
    kwargs["precision"] = precision.resolve(str(kwargs.get("precision", "32-true")), accelerator)
    if precision.on_cpu(accelerator):
        torch.set_flush_denormal(True)
    return {**kwargs, **trainer_limits(cfg.train)}


class StepLimit(Callback):
    """Stops training after ``max_steps`` optimiser steps. Not Lightning's ``max_steps``: with it Lightning
    treats training as iteration-based and a run resumed from an epoch-end checkpoint replays that epoch's
    end and loses an epoch (Lightning 2.6; tests/reliability/test_resume.py). Lightning validates when a stop
    is requested, so the last step is validated. A run resumed from a checkpoint at or past the budget (one
    killed during its test, resumed with ``ckpt_path=auto``) trains no step: it trained one more, past its
    budget, and recorded "stopped by the step budget (train.max_steps=3) after 4 steps"."""

    def __init__(self, max_steps: int) -> None:
        self.max_steps = max_steps

    def on_train_start(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        if trainer.global_step >= self.max_steps:
            trainer.should_stop = True

    def on_train_batch_end(self, trainer: L.Trainer, pl_module: L.LightningModule, outputs: object,
                           batch: object, batch_idx: int) -> None:
        if trainer.global_step >= self.max_steps:
            trainer.should_stop = True


def callbacks(train: DictConfig) -> list[Callback]:
    """The budget's callbacks: :class:`StepLimit` (``train.max_steps``) and early stopping on ``val/psnr``
    (``train.patience`` validations without a gain of ``train.min_delta`` dB)."""
    steps, patience = _limit(train, "max_steps"), train.get("patience")
    out: list[Callback] = [StepLimit(int(steps))] if steps is not None else []
    if patience is not None:
        out.append(EarlyStopping(monitor="val/psnr", mode="max", patience=int(patience),
                                 min_delta=float(train.get("min_delta", 0.0)), check_finite=True))
    return out


def stop_reason(trainer: L.Trainer, train: DictConfig, seconds: float) -> str:
    """Why training ended: ``plateau``, ``max_steps``, ``max_minutes``, ``epochs`` (or ``interrupted``).
    ``seconds`` is this process's time; the time budget is Lightning's ``Timer``'s, which a resumed run
    restores from its checkpoint, so a run resumed and then stopped by its budget says ``max_minutes`` (it
    said ``interrupted``: this process alone had not used the budget)."""
    if any(isinstance(c, EarlyStopping) and c.stopped_epoch > 0 for c in trainer.callbacks):
        return "plateau"
    timers = [c.time_elapsed("train") for c in trainer.callbacks if isinstance(c, Timer)]
    seconds = max([seconds, *timers])
    steps, minutes = _limit(train, "max_steps"), _limit(train, "max_minutes")
    if steps is not None and trainer.global_step >= steps:
        return "max_steps"
    if minutes is not None and seconds >= 0.98 * minutes * 60:
        return "max_minutes"
    epochs = _limit(train, "epochs")
    if epochs is not None and trainer.current_epoch >= epochs:
        return "epochs"
    return "interrupted"


class LearningCurve(Callback):
    """Appends one row of :data:`CURVE_COLUMNS` to ``path`` after every validation (rank 0), so that a
    resumed run keeps its earlier curve. ``seconds`` is wall clock since training started (a resumed run
    goes on from its last row's seconds)."""

    def __init__(self, path: str | Path) -> None:
        self.path = Path(path)
        self.started = math.nan
        self.last_step = -1  # the optimiser step of the last validation

    def on_train_start(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        """A resumed run first drops the rows a killed process wrote past the restored step from
        ``curve.csv`` and the CSV logger's ``metrics.csv`` (mcd/lit/csv_log.py), then continues the clock
        from the last row kept."""
        if trainer.global_step > 0 and trainer.is_global_zero:
            # curve.csv counts optimiser steps done; Lightning logs the rows of step k (from 1) at step k - 1
            kept = [(self.path, trainer.global_step)]
            kept += [(Path(lg.experiment.metrics_file_path), trainer.global_step - 1)
                     for lg in trainer.loggers if isinstance(lg, ResumableCSVLogger)]
            for path, last in kept:
                dropped = drop_rows_after(path, last)
                if dropped:
                    log.info("%s: %d rows past the resumed checkpoint (logged by the interrupted process) "
                             "dropped", path, dropped)
        offset = 0.0  # a resumed run continues its clock from the last row written
        if trainer.global_step > 0 and self.path.is_file():
            with self.path.open(newline="") as f:
                rows = list(csv.DictReader(f))
            offset = float(rows[-1]["seconds"]) if rows else 0.0
        self.started = time.perf_counter() - offset

    def on_validation_end(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        if trainer.sanity_checking:
            return
        self.last_step = trainer.global_step  # on every rank: :func:`finish` validates on all or on none
        if not trainer.is_global_zero:
            return
        metrics = trainer.callback_metrics

        def value(key: str) -> float:
            return float(metrics[key]) if key in metrics else math.nan

        opt = trainer.optimizers[0] if trainer.optimizers else None
        row = {"step": trainer.global_step, "epoch": trainer.current_epoch,
               "seconds": round(time.perf_counter() - self.started, 3),
               "lr": opt.param_groups[0]["lr"] if opt is not None else math.nan,
               "train_loss": value("train/loss_epoch") if "train/loss_epoch" in metrics
               else value("train/loss_step"),
               "val_loss": value("val/loss"), "val_psnr": value("val/psnr"), "val_ssim": value("val/ssim")}
        new = not self.path.is_file()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with self.path.open("a", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=CURVE_COLUMNS)
            if new:
                writer.writeheader()
            writer.writerow(row)


class OwnBest(Callback):
    """Keeps the best-checkpoint record of a run to its own ``checkpoints/`` folder. A checkpoint from
    another directory (``ckpt_path=<another run's last.ckpt>``, or a run directory copied elsewhere and
    resumed) carries that directory's best checkpoint path, which Lightning restores even where the folder
    differs; :func:`finish` then deleted that file, the best checkpoint of another, finished run, when it
    found a better one. The path is forgotten at the start of training (the run's own validations choose its
    best), and :func:`finish` never deletes outside the run's folder."""

    def __init__(self, best: ModelCheckpoint) -> None:
        self.best = best

    def on_train_start(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        path, folder = self.best.best_model_path, Path(str(self.best.dirpath)).resolve()
        if path and Path(path).resolve().parent != folder:
            log.info("the checkpoint resumed from names %s as its best; this run keeps its own best in %s",
                     path, folder)
            self.best.best_model_path, self.best.best_model_score = "", None


def finish(trainer: L.Trainer, module: L.LightningModule, datamodule: L.LightningDataModule,
           best: ModelCheckpoint, curve: LearningCurve) -> None:
    """After ``fit``: validate the final weights if the last validation came before the last step (a budget
    that ends between two validations), keep them as the best checkpoint when their ``val/psnr`` is higher,
    and rewrite ``last.ckpt`` with the final weights (the ``last`` checkpoint callback of mcd.run writes it at
    every validation inside ``fit``, not at this one)."""
    folder = Path(best.dirpath)
    if curve.last_step != trainer.global_step:  # else the last validation already wrote last.ckpt (mcd.run)
        trainer.validate(module, datamodule=datamodule, verbose=False)
        score = trainer.callback_metrics.get("val/psnr")
        previous = best.best_model_score
        if score is not None and (previous is None or float(score) > float(previous)):
            path = folder / f"best-step{trainer.global_step:06d}.ckpt"
            trainer.save_checkpoint(path)
            previous_path = Path(best.best_model_path) if best.best_model_path else None
            if previous_path and previous_path != path and previous_path.resolve().parent == folder.resolve():
                previous_path.unlink(missing_ok=True)
            best.best_model_path, best.best_model_score = str(path), score
        trainer.save_checkpoint(folder / "last.ckpt")

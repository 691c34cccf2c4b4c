"""Where a training run stands, in one line (docs/training.md, "Progress and summary").

:class:`ProgressLine` replaces Lightning's tqdm bars (``mcd.run`` passes it while
``trainer.enable_progress_bar`` is true). Its line holds the global optimiser step against the step budget
(``train.max_steps``, or ``train.epochs`` times the batches of an epoch), the minutes against
``train.max_minutes``, the last training loss, the last validation PSNR, seconds per step and the time left
(the sooner of the step and the time budget). On a terminal the line is rewritten in place; when the output
is not a terminal (a log file, a pipe, a cluster job) it is printed as a plain line every
:data:`LOG_EVERY_S` seconds, after every validation and at the end, with no carriage return, so a log stays
small and readable.
"""

from __future__ import annotations

import math
import shutil
import sys
import time
from typing import IO, Any

import lightning as L
from lightning.pytorch.callbacks import ProgressBar, Timer
from omegaconf import DictConfig

#: Seconds between two progress lines when the output is not a terminal.
LOG_EVERY_S = 30.0
#: Seconds between two redraws of the line on a terminal.
REDRAW_EVERY_S = 0.5


def _minutes(seconds: float) -> str:
    return f"{seconds / 60:.1f} min" if seconds >= 60 else f"{seconds:.0f} s"


class ProgressLine(ProgressBar):
    """One progress line of a training run (see the module docstring); silent during validation and test
    (their results show in the line, and in the summary of ``mcd.run``)."""

    def __init__(self, train: DictConfig, stream: IO[str] | None = None, tty: bool | None = None) -> None:
        super().__init__()
        self.stream = stream if stream is not None else sys.stdout
        self.tty = bool(self.stream.isatty()) if tty is None else tty
        self.every_s = REDRAW_EVERY_S if self.tty else LOG_EVERY_S
        self.max_steps = None if train.get("max_steps") is None else int(train.max_steps)
        self.epochs = None if train.get("epochs") is None else int(train.epochs)
        self.max_minutes = None if train.get("max_minutes") is None else float(train.max_minutes)
        self._enabled = True
        self._t0 = math.nan
        self._start_step = 0
        self._last_print = -math.inf
        self._val: tuple[int, float] | None = None  # (step, val/psnr) of the last validation

    def disable(self) -> None:
        """Lightning's switch (e.g. on the ranks other than 0)."""
        self._enabled = False

    def enable(self) -> None:
        self._enabled = True

    def step_budget(self, trainer: L.Trainer) -> int | None:
        """The optimiser steps the run may take: the sooner of ``train.max_steps`` and the epochs' batches."""
        budgets = [self.max_steps] if self.max_steps is not None else []
        batches = trainer.num_training_batches
        if self.epochs is not None and isinstance(batches, int | float) and math.isfinite(batches):
            budgets.append(self.epochs * int(batches))
        return min(budgets) if budgets else None

    def line(self, trainer: L.Trainer) -> str:
        """The progress line as it stands now."""
        step = int(trainer.global_step)
        elapsed = time.perf_counter() - self._t0
        total = self.step_budget(trainer)
        parts = [f"step {step}/{total} ({100 * step / max(total, 1):.0f}%)" if total else f"step {step}",
                 f"epoch {trainer.current_epoch}"]
        timer = next((c for c in trainer.callbacks if isinstance(c, Timer)), None)
        if self.max_minutes is not None:
            used = timer.time_elapsed("train") if timer is not None else elapsed
            parts.append(f"{used / 60:.1f}/{self.max_minutes:g} min")
        loss = trainer.callback_metrics.get("train/loss_step", trainer.callback_metrics.get("train/loss"))
        if loss is not None:
            parts.append(f"loss {float(loss):.4g}")
        if self._val is not None:
            parts.append(f"val PSNR {self._val[1]:.2f} dB (step {self._val[0]})")
        done = step - self._start_step
        if done > 0:
            per_step = elapsed / done
            parts.append(f"{per_step:.2f} s/step")
            left = [(total - step) * per_step] if total else []
            if timer is not None and self.max_minutes is not None:
                remaining = timer.time_remaining("train")
                if remaining is not None:
                    left.append(remaining)
            if left:
                parts.append(f"ETA {_minutes(max(min(left), 0.0))}")
        return "train: " + " | ".join(parts)

    def _show(self, trainer: L.Trainer, force: bool = False) -> None:
        now = time.perf_counter()
        due = force or now - self._last_print >= self.every_s
        if not due or not self._enabled or not trainer.is_global_zero:
            return
        self._last_print = now
        text = self.line(trainer)
        if self.tty:
            width = shutil.get_terminal_size((120, 20)).columns - 1
            self.stream.write("\r" + text[:width].ljust(width))
        else:
            self.stream.write(text + "\n")
        self.stream.flush()

    def on_train_start(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        self._t0 = time.perf_counter()
        self._start_step = int(trainer.global_step)
        self._last_print = time.perf_counter()  # the first line after every_s, or at the first validation

    def on_train_batch_end(self, trainer: L.Trainer, pl_module: L.LightningModule, outputs: Any, batch: Any,
                           batch_idx: int) -> None:
        self._show(trainer)

    def on_validation_end(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        if trainer.sanity_checking:
            return
        score = trainer.callback_metrics.get("val/psnr")
        if score is not None:
            self._val = (int(trainer.global_step), float(score))
        if not math.isnan(self._t0):
            self._show(trainer, force=True)

    def on_train_end(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        self._show(trainer, force=True)
        if self.tty and self._enabled and trainer.is_global_zero:
            self.stream.write("\n")
            self.stream.flush()


def callbacks(cfg: DictConfig) -> list[ProgressLine]:
    """``[ProgressLine]`` where ``trainer.enable_progress_bar`` is true (Lightning refuses a progress-bar
    callback otherwise), else ``[]``."""
    return [ProgressLine(cfg.train)] if cfg.trainer.get("enable_progress_bar", True) else []

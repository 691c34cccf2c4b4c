"""Which code trained which steps of a run (docs/architecture.md, "Run directory": ``segments``).

A run killed mid-training resumes from its ``last.ckpt`` (``ckpt_path=auto``, mcd.run), possibly in a later
process running later code. ``metrics.json``'s ``commit`` names the code of the process that finished the run;
:class:`TrainingSegments` keeps, in every checkpoint it saves (Lightning's callback state), one record per
process that trained: the commit and dirty flag of its code, its device, its resolved Lightning precision, the
optimiser steps it started and ended at, and its seconds of training. A resumed run reads them back and
appends its own, so ``segments`` names the code behind every step. A checkpoint from before these records,
resumed at step ``n > 0``, gives a first segment ``0 .. n`` whose ``commit`` is null (not recorded). A resume
in another precision than the last segment's is allowed (``trainer.precision=auto`` resolves per machine) and
named in a warning; each segment records its own (``metrics.json``'s ``precision`` names the last process's).

Each checkpoint also holds the record of the job that trained it (``job``:
:func:`mcd.lit.run_record.job_record`), so that a resume is checked against it even where the run
directory's ``job.json`` is lost, or the checkpoint is another directory's (:func:`recorded_job`; a
checkpoint from before the record is checked against its run directory's ``job.json``; docs/reliability.md,
"Campaign fixes").
"""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path
from typing import Any

import lightning as L
from lightning.pytorch.callbacks import Callback

from mcd.core.machine import device_name

log = logging.getLogger(__name__)


class TrainingSegments(Callback):
    """Records the training segments of a run (see the module docstring); :meth:`records` lists them."""

    def __init__(self, code: dict[str, object], job: dict[str, Any] | None = None) -> None:
        self.job = job  # the job that trains (mcd.lit.run_record.job_record), saved in every checkpoint
        self.code = {"commit": code.get("commit"), "dirty": code.get("dirty")}
        self.device: str | None = None  # named when training starts, on the device it runs on
        self.precision: str | None = None  # Lightning's resolved precision, named when training starts
        self.earlier: list[dict[str, Any]] = []  # the segments read back from the resumed checkpoint
        self.start_step: int | None = None  # None until this process trains
        self.end_step = 0
        self.started = 0.0

    @property
    def state_key(self) -> str:
        return "TrainingSegments"

    def load_state_dict(self, state_dict: dict[str, Any]) -> None:
        self.earlier = [dict(s) for s in state_dict.get("segments", [])]

    def state_dict(self) -> dict[str, Any]:
        return {"segments": self.records(), "job": self.job}

    def on_train_start(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        self.start_step = self.end_step = int(trainer.global_step)
        self.device = device_name(pl_module.device)
        self.precision = str(trainer.precision)
        self.started = time.perf_counter()
        recorded = self.earlier[-1]["end_step"] if self.earlier else 0
        before = self.earlier[-1].get("precision") if self.earlier else None
        if before is not None and before != self.precision:
            log.warning("this run's steps %s to %s trained in precision %s; this process trains in %s "
                        "(trainer.precision): metrics.json's segments record each", self.earlier[-1].get(
                            "start_step"), recorded, before, self.precision)
        if self.start_step > recorded:  # a checkpoint from before these records (or one that lost them)
            self.earlier.append({"commit": None, "dirty": None, "device": None, "precision": None,
                                 "start_step": recorded, "end_step": self.start_step, "seconds": None})

    def on_train_batch_end(self, trainer: L.Trainer, pl_module: L.LightningModule, outputs: object,
                           batch: object, batch_idx: int) -> None:
        self.end_step = int(trainer.global_step)

    def records(self) -> list[dict[str, Any]]:
        """The segments so far, oldest first: the resumed checkpoint's, then this process's if it trained."""
        if self.start_step is None:
            return list(self.earlier)
        ours = {**self.code, "device": self.device, "precision": self.precision,
                "start_step": self.start_step, "end_step": self.end_step,
                "seconds": round(time.perf_counter() - self.started, 3)}
        return [*self.earlier, ours]


def recorded_job(checkpoint: dict[str, Any], path: Path) -> dict[str, Any] | None:
    """The job record a checkpoint (loaded with ``weights_only=True`` from ``path``) holds; for one from
    before it, the ``job.json`` of the run directory it lies in (``<run>/checkpoints/<name>.ckpt``), else
    None."""
    state = (checkpoint.get("callbacks") or {}).get("TrainingSegments")
    job = state.get("job") if isinstance(state, dict) else None
    if isinstance(job, dict):
        return job
    beside = path.parent.parent / "job.json"
    if path.parent.name != "checkpoints" or not beside.is_file():
        return None
    try:
        job = json.loads(beside.read_text())
    except (OSError, ValueError):
        return None
    return job if isinstance(job, dict) else None

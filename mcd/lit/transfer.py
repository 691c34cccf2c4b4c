"""Transfer to held-out scenes (docs/benchmark.md "Experiments", transfer): a model trained on the training
scenes is tested on `data.transfer_scenes`, as loaded or after a brief fine-tuning on the held-out scenes.

Keys (`conf/config.yaml`):
- `transfer.init_from`: a trained run directory (its `checkpoints/best*.ckpt`, else `last.ckpt`) or a `.ckpt`
  file; null = no transfer (an ordinary run).
- `transfer.finetune_epochs`: 0 = test the loaded weights as they are; n > 0 = fine-tune n epochs first
  (paper: 30), on the training split of the held-out scenes (never their test frames).
- `transfer.finetune_clips`: training batches per fine-tuning epoch, at batch size 1, so each epoch sees that
  many 5-frame clips (paper: 1 clip). The clip is drawn at random each epoch from the held-out scenes'
  training split, where the paper kept one fixed clip.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf, open_dict
from torch import nn

from mcd.lit import checkpoint

log = logging.getLogger(__name__)


def checkpoint_of(init_from: str | Path) -> Path:
    """The checkpoint file `init_from` names: itself, or a run dir's best checkpoint (else its last)."""
    path = Path(init_from)
    if path.is_file():
        return path
    best = sorted((path / "checkpoints").glob("best*.ckpt"))
    last = path / "checkpoints" / "last.ckpt"
    if best:
        return best[-1]
    if last.is_file():
        return last
    raise FileNotFoundError(
        f"transfer.init_from={init_from}: no checkpoint file and no run dir with checkpoints/best*.ckpt or "
        "last.ckpt; train the model first (python -m mcd.run -m +sweep=baselines, same data profile)"
    )


def identity(cfg: DictConfig) -> dict[str, Any] | None:
    """What of ``cfg``'s transfer makes a run another job (:func:`mcd.lit.run_record.job_identity`): the
    checkpoint it starts from (as :func:`prepare` records it: the file :func:`checkpoint_of` finds, or the
    path as given where it finds none) and the fine-tuning; None for an ordinary run. A rerun with another
    source run or fine-tuning was skipped as finished, its ``metrics.json`` the first transfer's."""
    t = cfg.get("transfer")
    if t is None or not t.get("init_from"):
        return None
    try:
        ckpt = str(checkpoint_of(t.init_from))
    except FileNotFoundError:
        ckpt = str(t.init_from)
    epochs = int(t.get("finetune_epochs", 0))
    return {"init_from": ckpt, "finetune_epochs": epochs,
            "finetune_clips": int(t.get("finetune_clips", 1)) if epochs > 0 else 0}


def prepare(cfg: DictConfig) -> tuple[DictConfig, dict[str, Any] | None]:
    """The run config of a transfer job and what to record about it (`None`, unchanged cfg: no transfer).

    Trains (fine-tunes) and tests on `data.transfer_scenes` only; `train.epochs` = `finetune_epochs`.
    """
    t = cfg.get("transfer")
    if t is None or not t.get("init_from"):
        return cfg, None
    scenes = list(cfg.data.get("transfer_scenes") or [])
    if not scenes:
        raise ValueError(
            f"transfer.init_from is set but data.transfer_scenes is empty (profile {cfg.data.get('name')}): "
            "name held-out scenes, e.g. +scene@data.scenes.cornell-box-picture=cornell-box-picture "
            "'data.transfer_scenes=[cornell-box-picture]'"
        )
    overlap = sorted(set(scenes) & set(cfg.data.get("train_scenes") or []))
    if overlap:
        raise ValueError(f"data.transfer_scenes {overlap} are also training scenes: they are not held out")
    epochs = int(t.get("finetune_epochs", 0))
    if epochs < 0:
        raise ValueError(f"transfer.finetune_epochs={epochs}: must be >= 0")
    ckpt = checkpoint_of(t.init_from)
    cfg = OmegaConf.create(OmegaConf.to_container(cfg, resolve=True))
    with open_dict(cfg):
        cfg.data.train_scenes = scenes
        cfg.data.test_scenes = scenes
        cfg.train.epochs = epochs  # the fine-tuning budget is epochs alone (mcd.lit.budget)
        cfg.train.max_steps = None
        cfg.train.max_minutes = None
        cfg.train.patience = None
        cfg.train.val_every_steps = None
        if epochs > 0:
            cfg.train.batch_size = 1
            cfg.train.limit_train_batches = int(t.get("finetune_clips", 1))
    info = {"scene": ", ".join(scenes), "scenes": scenes, "finetune": epochs > 0, "finetune_epochs": epochs,
            "finetune_clips": int(t.get("finetune_clips", 1)) if epochs > 0 else 0, "init_from": str(ckpt)}
    return cfg, info


def load_weights(model: nn.Module, info: dict[str, Any]) -> None:
    """Load the trained weights (a Lightning checkpoint of `DenoiseModule`: keys `model.*`) into `model`.

    The file is read with `weights_only=True` (:func:`mcd.lit.checkpoint.safe_load`); a checkpoint that does
    not fit `model` raises :class:`mcd.lit.checkpoint.CheckpointError` naming what differs.
    """
    key = "transfer.init_from"
    weights = checkpoint.model_weights(checkpoint.safe_load(info["init_from"], key))
    checkpoint.check_fits(model, weights, key, info["init_from"])
    model.load_state_dict(weights)
    log.info("transfer: weights from %s; %s", info["init_from"],
             f"fine-tuning {info['finetune_epochs']} epochs on {info['scene']}" if info["finetune"]
             else f"testing on {info['scene']} as loaded")

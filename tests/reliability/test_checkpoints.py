"""Checkpoints are loaded weights-only, and one that does not fit the run's
model is refused, naming what differs, before anything is rendered."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest
import torch

from mcd.lit import transfer
from mcd.lit.checkpoint import CheckpointError
from mcd.models import build
from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides


class _Payload:
    """Unpickling this runs ``touch <marker>``, as a crafted checkpoint would run any shell command."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return os.system, (f"touch {self.marker}",)


def _crafted(tmp_path: Path) -> tuple[Path, Path]:
    """A checkpoint file with real-looking weights plus the payload, and the file the payload would write."""
    marker = tmp_path / "pwned"
    path = tmp_path / "crafted.ckpt"
    torch.save({"state_dict": {"model.w": torch.zeros(2)}, "extra": _Payload(marker)}, path)
    return path, marker


def test_the_crafted_checkpoint_runs_code_when_fully_unpickled(tmp_path):
    """Control: the payload does write its file under ``weights_only=False`` (what the old code used)."""
    path, marker = _crafted(tmp_path)
    torch.load(path, weights_only=False)
    assert marker.exists()


def test_a_crafted_transfer_checkpoint_is_refused_without_running_code(tmp_path):
    path, marker = _crafted(tmp_path)
    info = {"init_from": str(path), "finetune": False, "finetune_epochs": 0, "scene": "x"}
    refused = r"transfer\.init_from=.*crafted\.ckpt: refused.*could run code"
    with pytest.raises(CheckpointError, match=refused):
        transfer.load_weights(torch.nn.Linear(2, 2), info)
    assert not marker.exists()


def test_a_crafted_resume_checkpoint_is_refused_before_rendering(tmp_path):
    path, marker = _crafted(tmp_path)
    cfg = compose_cfg(*store32_overrides(tmp_path / "data"), "+experiment=F", f"ckpt_path={path}")
    with pytest.raises(CheckpointError, match=r"ckpt_path=.*crafted\.ckpt: refused"):
        train_and_test(cfg, tmp_path / "run", {}, time.perf_counter())
    assert not marker.exists() and not (tmp_path / "data").exists()


def test_another_experiments_checkpoint_is_named_before_rendering(tmp_path):
    """Defect 10: row A's weights given to row F fail at once, naming what differs."""
    a = build(compose_cfg("+experiment=A"))
    path = tmp_path / "a.ckpt"
    torch.save({"state_dict": {f"model.{k}": v for k, v in a.state_dict().items()}}, path)
    cfg = compose_cfg(*store32_overrides(tmp_path / "data"), "+experiment=F", f"ckpt_path={path}")
    with pytest.raises(CheckpointError, match=r"ckpt_path=.*a\.ckpt: the checkpoint does not fit this model "
                                              r"\(missing \[.*same experiment"):
        train_and_test(cfg, tmp_path / "run", {}, time.perf_counter())
    assert not (tmp_path / "data").exists()


def test_a_shape_mismatch_names_the_parameter(tmp_path):
    path = tmp_path / "lin.ckpt"
    torch.save({"state_dict": {f"model.{k}": v for k, v in torch.nn.Linear(3, 2).state_dict().items()}}, path)
    info = {"init_from": str(path), "finetune": False, "finetune_epochs": 0, "scene": "x"}
    with pytest.raises(CheckpointError, match=r"shape differs for weight \(2, 3\) vs \(2, 2\)"):
        transfer.load_weights(torch.nn.Linear(2, 2), info)

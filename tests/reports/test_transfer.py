"""mcd/lit/transfer.py: a transfer job's config (held-out scenes only, fine-tuning budget), its errors."""

from __future__ import annotations

import pytest
import torch
from omegaconf import OmegaConf
from torch import nn

from mcd.lit import budget, transfer


def _cfg(tmp_path, **t):
    return OmegaConf.create(
        {
            "data": {
                "name": "tiny",
                "train_scenes": ["cbox"],
                "test_scenes": ["cbox"],
                "transfer_scenes": ["cornell-box-picture"],
            },
            "train": {"epochs": 30, "batch_size": 4, "limit_train_batches": 1.0},
            "trainer": {"accelerator": "cpu"},
            "transfer": {"init_from": None, "finetune_epochs": 0, "finetune_clips": 1, **t},
        }
    )


def _ckpt(tmp_path, model: nn.Module):
    run = tmp_path / "run"
    (run / "checkpoints").mkdir(parents=True)
    state = {f"model.{k}": v for k, v in model.state_dict().items()}
    torch.save({"state_dict": state}, run / "checkpoints" / "best-epoch004.ckpt")
    torch.save({"state_dict": {}}, run / "checkpoints" / "last.ckpt")
    return run


def test_no_init_from_is_an_ordinary_run(tmp_path):
    cfg = _cfg(tmp_path)
    assert transfer.prepare(cfg) == (cfg, None)


def test_transfer_trains_and_tests_on_held_out_scenes_only(tmp_path):
    run = _ckpt(tmp_path, nn.Linear(2, 2))
    cfg, info = transfer.prepare(_cfg(tmp_path, init_from=str(run), finetune_epochs=30, finetune_clips=1))
    assert list(cfg.data.train_scenes) == list(cfg.data.test_scenes) == ["cornell-box-picture"]
    assert cfg.train.limit_train_batches == 1 and cfg.train.batch_size == 1
    # the fine-tuning budget is its epochs alone, whatever step or time budget the profile had
    limits = budget.trainer_limits(cfg.train)
    assert limits["limit_train_batches"] == 1 and budget.trainer_kwargs(cfg)["limit_train_batches"] == 1
    assert limits["max_epochs"] == 30 and "max_time" not in limits and budget.callbacks(cfg.train) == []
    assert info["finetune"] and info["init_from"].endswith("best-epoch004.ckpt")
    cfg0, info0 = transfer.prepare(_cfg(tmp_path, init_from=str(run)))
    assert not info0["finetune"] and budget.trainer_limits(cfg0.train)["max_epochs"] == 0


def test_weights_are_loaded_and_a_mismatch_is_named(tmp_path):
    src = nn.Linear(2, 2)
    run = _ckpt(tmp_path, src)
    _, info = transfer.prepare(_cfg(tmp_path, init_from=str(run)))
    dst = nn.Linear(2, 2)
    transfer.load_weights(dst, info)
    assert torch.equal(dst.weight, src.weight)
    with pytest.raises(ValueError, match="does not fit this model"):
        transfer.load_weights(nn.Linear(3, 2), info)


def test_a_run_dir_without_a_best_checkpoint_falls_back_to_last(tmp_path):
    src = nn.Linear(2, 2)
    run = tmp_path / "run"
    (run / "checkpoints").mkdir(parents=True)
    torch.save({"state_dict": {f"model.{k}": v for k, v in src.state_dict().items()}},
               run / "checkpoints" / "last.ckpt")
    _, info = transfer.prepare(_cfg(tmp_path, init_from=str(run)))
    assert info["init_from"] == str(run / "checkpoints" / "last.ckpt")
    dst = nn.Linear(2, 2)
    assert not torch.equal(dst.weight, src.weight)
    transfer.load_weights(dst, info)
    assert torch.equal(dst.weight, src.weight) and torch.equal(dst.bias, src.bias)


def test_bad_transfer_configs_say_what_to_do(tmp_path):
    with pytest.raises(FileNotFoundError, match="train the model first"):
        transfer.prepare(_cfg(tmp_path, init_from=str(tmp_path / "missing")))
    cfg = _cfg(tmp_path, init_from="x")
    cfg.data.transfer_scenes = []
    with pytest.raises(ValueError, match="transfer_scenes is empty"):
        transfer.prepare(cfg)
    cfg = _cfg(tmp_path, init_from="x")
    cfg.data.transfer_scenes = ["cbox"]
    with pytest.raises(ValueError, match="not held out"):
        transfer.prepare(cfg)

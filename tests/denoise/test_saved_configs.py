"""Saved configs (docs/architecture.md "Config"): the bundled checkpoints' JSON configs are on today's schema
(every key today's experiment config has) and build their models; a config of an older schema (the group
``model``, today ``capacity``; a method section without a key today's has, or with one it no longer has)
gets one error naming the re-save command; a run checkpoint on today's schema loads."""

from __future__ import annotations

import json

import pytest
import torch
from omegaconf import OmegaConf, open_dict

from mcd.denoise.weights import BUNDLED_DIR, bundled_names, load
from mcd.lit.checkpoint import CheckpointError
from mcd.losses import build_loss
from mcd.models import build
from tests.conftest import compose_cfg


@pytest.mark.slow
def test_every_bundled_checkpoint_builds_and_loads_through_the_registry():
    assert bundled_names()
    for name in bundled_names():
        loaded = load(name)
        cfg = json.loads((BUNDLED_DIR / f"{name}.json").read_text())["config"]
        # on today's schema: the method section has every key today's has, and no other
        today_cfg = compose_cfg(f"+experiment={cfg['experiment']}", f"budget={cfg['budget']}")
        method = OmegaConf.to_container(today_cfg.method, resolve=True)
        assert set(cfg["method"]) == set(method) and set(cfg["method"]["kp"]) == set(method["kp"]), name
        # the model built today from the old config is the one built from today's experiment config at the
        # bundle's own widths and method settings (a bundle keeps what it was trained with when a profile or
        # a method's default changes)
        with open_dict(today_cfg):
            today_cfg.capacity = cfg["capacity"]
            today_cfg.method = cfg["method"]
        today = build(today_cfg)
        shapes = [tuple(p.shape) for p in today.parameters()]
        assert [tuple(p.shape) for p in loaded.model.parameters()] == shapes


def _old(meta: dict) -> dict:
    """A bundle JSON as it was saved before the ``capacity`` group had its name."""
    config = {("model" if k == "capacity" else k): v for k, v in meta["config"].items()}
    return {**meta, "config": config}


def test_a_bundle_of_an_older_schema_is_refused_naming_the_resave_command(tmp_path):
    name = bundled_names()[0]
    meta = json.loads((BUNDLED_DIR / f"{name}.json").read_text())
    (tmp_path / f"{name}.json").write_text(json.dumps(_old(meta)))
    (tmp_path / f"{name}.pt").write_bytes((BUNDLED_DIR / f"{name}.pt").read_bytes())
    with pytest.raises(CheckpointError, match=r"lacks capacity.*python -m mcd\.bundle RUN_DIR --name NAME"):
        load(str(tmp_path / f"{name}.pt"))


def _run_checkpoint(tmp_path, cfg, saved: dict) -> str:
    """A run directory whose last checkpoint holds ``cfg``'s model and the saved config ``saved``."""
    state = {"state_dict": {f"model.{k}": v for k, v in build(cfg).state_dict().items()},
             "hyper_parameters": {"cfg": saved}, "global_step": 1}
    (tmp_path / "checkpoints").mkdir(exist_ok=True)
    torch.save(state, tmp_path / "checkpoints" / "last.ckpt")
    return str(tmp_path)


def test_a_run_checkpoint_of_an_older_schema_is_refused_naming_the_resave_command(tmp_path):
    cfg = compose_cfg("+experiment=A")
    old = OmegaConf.to_container(cfg, resolve=True)
    old["model"] = old.pop("capacity")
    with pytest.raises(CheckpointError, match=r"schema \(lacks 'capacity'\).*python -m mcd\.bundle"):
        load(_run_checkpoint(tmp_path, cfg, old))


def test_a_run_checkpoint_on_todays_schema_loads_and_one_off_it_is_refused(tmp_path):
    cfg = compose_cfg("+experiment=A")
    saved = OmegaConf.to_container(cfg, resolve=True)
    loaded = load(_run_checkpoint(tmp_path, cfg, saved))
    assert loaded.experiment == "A"
    without = {**saved, "method": {k: v for k, v in saved["method"].items() if k != "colour"}}
    with pytest.raises(CheckpointError, match=r"lacks 'method.colour'.*python -m mcd\.bundle RUN_DIR"):
        load(_run_checkpoint(tmp_path, cfg, without))
    retired = {**saved, "method": {**saved["method"], "kp": {**saved["method"]["kp"], "ring": 2}}}
    with pytest.raises(CheckpointError, match=r"holds 'method.kp.ring'.*python -m mcd\.bundle RUN_DIR"):
        load(_run_checkpoint(tmp_path, cfg, retired))


def test_a_retired_loss_key_is_refused_naming_the_loss_file():
    cfg = compose_cfg("+experiment=A", "paths.vgg16_weights=null")
    with open_dict(cfg):
        cfg.loss.module = None
    with pytest.raises(ValueError, match=r"loss 'paper': its settings .*module.*conf/loss/paper\.yaml"):
        build_loss(cfg)

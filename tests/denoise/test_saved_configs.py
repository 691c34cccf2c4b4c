"""Saved configs (docs/architecture.md "Config"): the bundled checkpoints' JSON configs are on today's schema
(every key today's experiment config has) and build their models; a config of an older schema (the group
``model``, today ``capacity``) gets one error naming the re-save command; a run checkpoint whose config
names ``loss.module`` and ``trainer.limit_train_batches`` loads."""

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


def test_every_bundled_checkpoint_builds_and_loads_through_the_registry():
    assert bundled_names()
    for name in bundled_names():
        loaded = load(name)
        cfg = json.loads((BUNDLED_DIR / f"{name}.json").read_text())["config"]
        # the model built today from the old config is the one built from today's experiment config at the
        # bundle's own widths (a bundle keeps the widths it was trained with when a profile changes)
        today_cfg = compose_cfg(f"+experiment={cfg['experiment']}", f"budget={cfg['budget']}")
        with open_dict(today_cfg):
            today_cfg.capacity = cfg["capacity"]
        today = build(today_cfg)
        shapes = [tuple(p.shape) for p in today.parameters()]
        assert [tuple(p.shape) for p in loaded.model.parameters()] == shapes
        # on today's schema: the method section has every key today's has, and no other
        method = OmegaConf.to_container(today_cfg.method, resolve=True)
        assert set(cfg["method"]) == set(method) and set(cfg["method"]["kp"]) == set(method["kp"]), name


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


def test_a_run_checkpoint_of_an_older_schema_is_refused_naming_the_resave_command(tmp_path):
    cfg = compose_cfg("+experiment=A")
    old = OmegaConf.to_container(cfg, resolve=True)
    old["model"] = old.pop("capacity")
    state = {"state_dict": {f"model.{k}": v for k, v in build(cfg).state_dict().items()},
             "hyper_parameters": {"cfg": old}, "global_step": 1}
    (tmp_path / "checkpoints").mkdir()
    torch.save(state, tmp_path / "checkpoints" / "last.ckpt")
    with pytest.raises(CheckpointError, match=r"schema \(holds 'model'\).*python -m mcd\.bundle"):
        load(str(tmp_path))


def test_a_run_checkpoint_with_retired_keys_loads(tmp_path):
    """A ``mcd.run`` checkpoint carries the resolved config; the keys this refactor retired stay harmless."""
    cfg = compose_cfg("+experiment=A")
    old = OmegaConf.to_container(cfg, resolve=True)
    old["loss"]["module"] = None                                   # retired: loss modules are built-in
    old["loss"].pop("vgg16_weights")                               # not written before mcd/losses/
    old["trainer"]["limit_train_batches"] = old["train"]["limit_train_batches"]  # retired: train.* owns it
    for key in ("colour",):                                         # not written before conf/method/
        old["method"].pop(key)
    model = build(cfg)
    state = {"state_dict": {f"model.{k}": v for k, v in model.state_dict().items()},
             "hyper_parameters": {"cfg": old}, "global_step": 1}
    (tmp_path / "checkpoints").mkdir()
    torch.save(state, tmp_path / "checkpoints" / "last.ckpt")
    loaded = load(str(tmp_path))
    assert loaded.experiment == "A"
    for k, v in model.state_dict().items():
        assert torch.equal(loaded.model.state_dict()[k], v)
    assert build_loss(OmegaConf.create(old)) is not None

"""The config group ``model`` is now ``capacity`` (mcd/config.py, docs/architecture.md "Config"):
the old override is refused before any work, naming the new group, and configs saved before the rename (a
bundle's JSON, a run's checkpoint, a run directory's ``.hydra/`` choices, a bench row) still load."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from omegaconf import OmegaConf

from mcd.config import compose, upgrade_saved
from mcd.denoise.weights import BUNDLED_DIR, bundled_names, load
from mcd.models import build
from mcd.reporting.runs import load_run
from tests.conftest import compose_cfg

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("override", ["model=paper", "model=cpu", "+model=cpu", "model.rae.bottleneck=8"])
def test_the_old_group_is_refused_naming_the_new_one(override):
    with pytest.raises(ValueError, match=r"'model' is now called 'capacity'") as err:
        compose(["+experiment=F", override])
    assert f"give {override.replace('model', 'capacity', 1)}" in str(err.value)


def test_the_new_group_composes():
    assert compose(["capacity=paper"]).capacity.two_stage.denoiser.widths[0] == 32
    assert "model" not in compose()


@pytest.mark.parametrize("command", [
    ["mcd.run", "+experiment=F", "model=paper"],  # a Hydra command (mcd.config.hydra_main)
    ["mcd.run", "model.x=1"],
    ["mcd.bench", "speed", "model=cpu"],  # the tools that take Hydra overrides on an argparse line
    ["mcd.bench", "profile", "--synthetic", "model=cpu"],
    ["mcd.bench", "train", "model=cpu"],
    ["tools/bundle_scores.py", "model=cpu"],  # a lab tool (tools/README.md), run from the checkout
], ids=lambda c: " ".join(c))
@pytest.mark.slow
def test_a_command_line_naming_the_old_group_ends_in_one_error_line_before_any_work(tmp_path, command):
    """Exit status 2 and one line, ``error: <override>: ... give capacity...``, with no traceback and nothing
    written (a run's default directory would land in the working directory)."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
    where = [str(REPO / command[0])] if command[0].endswith(".py") else ["-m", command[0]]
    done = subprocess.run([sys.executable, *where, *command[1:]], capture_output=True, text=True, env=env,
                          cwd=tmp_path, timeout=300)
    old = command[-1]
    assert done.returncode == 2, done.stderr
    assert "Traceback" not in done.stderr
    assert done.stderr.splitlines() == [
        f"error: {old}: the config group 'model' is now called 'capacity' (conf/capacity/, the capacity "
        f"profiles; docs/architecture.md); give {old.replace('model', 'capacity', 1)}"]
    assert not any(tmp_path.iterdir())


def _as_before_the_rename(config: dict) -> dict:
    """A config as written before the rename: its ``capacity`` section under ``model``."""
    return {("model" if k == "capacity" else k): v for k, v in config.items()}


@pytest.mark.parametrize("name", bundled_names())
def test_a_bundle_saved_before_the_rename_loads(tmp_path, name):
    """The shipped bundle's real JSON and weights, its config keyed ``model:`` as the bundles were written."""
    meta = json.loads((BUNDLED_DIR / f"{name}.json").read_text())
    meta["config"] = _as_before_the_rename(meta["config"])
    assert "model" in meta["config"] and "capacity" not in meta["config"]
    shutil.copy(BUNDLED_DIR / f"{name}.pt", tmp_path / f"{name}.pt")
    (tmp_path / f"{name}.json").write_text(json.dumps(meta))
    loaded = load(str(tmp_path / f"{name}.pt"), capacity=None)
    assert OmegaConf.to_container(loaded.cfg.capacity) == meta["config"]["model"]
    # the same weights as the shipped bundle, whichever key it holds
    for k, v in load(name).model.state_dict().items():
        assert torch.equal(loaded.model.state_dict()[k], v)


def test_a_run_saved_before_the_rename_loads(tmp_path):
    """A run directory of ``mcd.run`` from before the rename: its checkpoint's config and its
    ``.hydra/hydra.yaml`` choices say ``model``; mcd-denoise loads it (with ``--capacity cpu``) and the report
    reads its capacity profile."""
    cfg = compose_cfg("+experiment=unet", "capacity=cpu")
    old = _as_before_the_rename(OmegaConf.to_container(cfg, resolve=True))
    model = build(cfg)
    state = {"state_dict": {f"model.{k}": v for k, v in model.state_dict().items()},
             "hyper_parameters": {"cfg": old}, "global_step": 1}
    (tmp_path / "checkpoints").mkdir()
    torch.save(state, tmp_path / "checkpoints" / "last.ckpt")
    (tmp_path / ".hydra").mkdir()
    OmegaConf.save(OmegaConf.create(old), tmp_path / ".hydra" / "config.yaml")
    OmegaConf.save(OmegaConf.create({"hydra": {"runtime": {"choices": {"model": "cpu", "data": "tiny"}}}}),
                   tmp_path / ".hydra" / "hydra.yaml")
    loaded = load(str(tmp_path), experiment="unet", capacity="cpu")
    for k, v in model.state_dict().items():
        assert torch.equal(loaded.model.state_dict()[k], v)
    with pytest.raises(Exception, match="not those of capacity=paper"):
        load(str(tmp_path), capacity="paper")
    run = load_run(tmp_path)
    assert run.choices["capacity"] == "cpu" and "capacity" in run.config


def test_upgrade_saved_keeps_what_is_already_new():
    assert upgrade_saved({"capacity": 1, "model": 2}) == {"capacity": 1, "model": 2}
    assert upgrade_saved({"model_profile": "cpu"}) == {"capacity_profile": "cpu"}
    assert upgrade_saved(None) is None

"""Defects 10, 11, 23, 24, 29 and 30 of the fourth reliability round: one check of every numeric key
(mcd/core/config_rules.py) that every Hydra command runs before any work. Each bad value ends the real command
with exit status 2 and one line ``error: <key>=<value>: ...``, no traceback, before anything is rendered or
written; every profile and experiment of conf/ passes it, and every numeric key there has a rule."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from mcd.config.compose import compose, experiment_names
from mcd.core.paths import CONF_DIR
from tests.conftest import store32_overrides

ROOT = Path(__file__).resolve().parents[2]


def _command(tmp_path: Path, module: str, *overrides: str, flags: tuple[str, ...] = ()) \
        -> subprocess.CompletedProcess:
    """``python -m <module>`` on the 32x32 profile of tests/conftest.py, its data and run in ``tmp_path``."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    args = [*store32_overrides(tmp_path / "data"), f"hydra.run.dir={tmp_path / 'run'}", *overrides]
    return subprocess.run([sys.executable, "-m", module, *flags, *args], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=180)


def _assert_refused(tmp_path: Path, proc: subprocess.CompletedProcess, key: str) -> str:
    """Exit 2, one ``error: <key>=`` line on stderr and nothing else, nothing written; returns the line."""
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert len(lines) == 1 and lines[0].startswith(f"error: {key}="), proc.stderr[-3000:]
    assert not (tmp_path / "data").exists() and not (tmp_path / "run").exists()
    assert not (tmp_path / "outputs").exists()
    return lines[0]


@pytest.mark.parametrize("override", [
    "train.max_steps=-1", "train.max_steps=0", "train.max_minutes=-5", "train.epochs=-1",
    "data.test_fraction=1.5", "train.lr=nan", "train.lr=-1", "data.clip_len=0",
])
def test_defect10_bad_training_values_are_named_before_rendering(tmp_path, override):
    _assert_refused(tmp_path, _command(tmp_path, "mcd.run", "+experiment=unet", override),
                    override.split("=")[0])


def test_defect11_the_plan_refuses_a_huge_frame_and_caps_its_pilot(tmp_path):
    from mcd.lit.workload import PILOT_MAX_PIXELS, pilot_size

    proc = _command(tmp_path, "mcd.plan", "data.width=100000", "data.height=100000")
    assert "16384" in _assert_refused(tmp_path, proc, "data.width")
    w, h = pilot_size(16384, 8192, 1)  # the largest frame the rule lets through, at pilot_scale=1
    assert w * h <= PILOT_MAX_PIXELS and abs(w / h - 2) < 0.05
    assert pilot_size(1920, 1080, 8) == (240, 135)  # the paper profile's pilot is not capped


@pytest.mark.parametrize("override", [
    "plan.pilot_scale=0", "plan.pilot_frames=0", "train.batch_size=0", "plan.pilot_spp=-1",
    "plan.step_crop=0", "data.width=abc", "data.segments=-1",
])
def test_defect23_the_plan_names_a_bad_key_without_a_traceback(tmp_path, override):
    _assert_refused(tmp_path, _command(tmp_path, "mcd.plan", override), override.split("=")[0])


@pytest.mark.parametrize("override", [
    "method.denoiser_margin=abc", "seed=-1", "train.batch_size=0", "data.ref_spp=0", "data.gbuffer_spp=0",
    "data.segments=0", "data.train_crop=0", "data.exposure_target=0", "data.val_clips=-1",
    "train.grad_clip=-1",
])
def test_defect24_the_run_names_the_key_it_refuses(tmp_path, override):
    proc = _command(tmp_path, "mcd.run", "+experiment=F", override)
    _assert_refused(tmp_path, proc, override.split("=")[0])


def test_defect29_a_shard_count_of_zero_says_so(tmp_path):
    line = _assert_refused(tmp_path, _command(tmp_path, "mcd.render", "render.shard=0/0"), "render.shard")
    assert "at least 1" in line and "from 0 to 0" not in line


def test_defect30_help_into_a_closed_pipe_ends_quietly(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    proc = subprocess.Popen([sys.executable, "-m", "mcd.run", "--help"], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stdout.close()  # the reader is gone before the help is written, as `| head` does
    err = proc.stderr.read()
    assert proc.wait(timeout=120) == 0, err
    assert "Traceback" not in err and "BrokenPipeError" not in err, err


@pytest.mark.parametrize("module", ["mcd.run", "mcd.render", "mcd.plan", "mcd.pack",
                                    "mcd.check_paths"])
@pytest.mark.slow
def test_every_hydra_command_checks_the_config_before_any_work(tmp_path, module):
    _assert_refused(tmp_path, _command(tmp_path, module, "data.clip_len=0"), "data.clip_len")


@pytest.mark.slow
def test_a_sweep_job_with_a_bad_value_writes_its_error_and_the_sweep_goes_on(tmp_path):
    """In a multirun the check is the job's: ``mcd.run`` writes its ``error.json`` (mcd/lit/hydra_callbacks.py
    then exits 1 naming the failed jobs), as for any job that fails."""
    proc = _command(tmp_path, "mcd.run", "+experiment=unet", "seed=-1", f"hydra.sweep.dir={tmp_path / 'sw'}",
                    flags=("-m",))
    assert proc.returncode == 1, proc.stderr[-3000:]
    (error,) = (tmp_path / "sw").rglob("error.json")
    assert "seed=-1: give a whole number from 0" in error.read_text()
    assert not (tmp_path / "data").exists()


def _profiles() -> list[list[str]]:
    groups = [[f"{g}={p.stem}"] for g in ("data", "train", "capacity", "trainer", "loss")
              for p in sorted((CONF_DIR / g).glob("*.yaml"))]
    sweeps = [[f"+sweep={p.stem}"] for p in sorted((CONF_DIR / "sweep").glob("[!_]*.yaml"))]
    return groups + sweeps + [[f"+experiment={e}"] for e in experiment_names()]


@pytest.mark.parametrize("overrides", _profiles(), ids=lambda o: o[0])
def test_every_profile_and_experiment_passes_and_every_numeric_key_has_a_rule(overrides):
    """Every profile of the groups data, train, capacity, trainer and loss, every sweep and experiment."""
    from mcd.core.config_rules import check_config, rule_of

    cfg = compose(overrides)
    check_config(cfg)

    def numeric(value: object) -> bool:
        if isinstance(value, list):
            return any(numeric(v) for v in value)
        return isinstance(value, int | float) and not isinstance(value, bool)

    def leaves(node: object, prefix: str = ""):
        if isinstance(node, dict):
            for k, v in node.items():
                yield from leaves(v, f"{prefix}.{k}" if prefix else str(k))
        else:
            yield prefix, node

    missing = [k for k, v in leaves(OmegaConf.to_container(cfg, resolve=False)) if numeric(v) and
               rule_of(k) is None]
    assert not missing, f"numeric keys without a rule in mcd/core/config_rules.py: {missing}"


@pytest.mark.parametrize(("key", "value", "message"), [
    ("train.max_steps", 1e3, None), ("train.max_steps", 2.5, "train.max_steps=2.5: give a whole number >= 1"),
    ("train.lr", float("inf"), "train.lr=inf: give a number from 0 to 10"),
    ("train.lr", True, "train.lr=True"), ("train.grad_clip", None, None),
    ("train.batch_size", None, "train.batch_size=null: give a whole number from 1"),
    ("capacity.rae.encoder", [8, 0],
     "capacity.rae.encoder=[8, 0]: give whole numbers from 1 to 4096 (0 is not)"),
])
def test_the_rules_read_types_ranges_and_null(key, value, message):
    from mcd.core.config_rules import ConfigError, checked

    if message is None:
        checked(key, value)
    else:
        with pytest.raises(ConfigError, match=re.escape(message)):
            checked(key, value)

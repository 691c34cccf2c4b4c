"""Rows A-M of the component study have one source, the table of :mod:`mcd.methods`: no
``conf/experiment/<row>.yaml`` repeats a row's switches; :mod:`mcd.config` registers each row in Hydra's
ConfigStore, and every way a config is composed (``compose``, ``python -m mcd.run``/``mcd.render``/
``mcd.plan``, a multirun on the joblib launcher, ``mcd-denoise --experiment``) takes the switches from the
table (docs/architecture.md, "Config")."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from mcd import methods
from mcd.config import compose, experiment_names
from mcd.methods import COMPONENTS
from mcd.models.switches import SWITCHES
from mcd.paths import CONF_DIR

REPO = Path(__file__).resolve().parents[1]


def test_no_yaml_file_repeats_a_component_row():
    assert not [r for r in COMPONENTS if (CONF_DIR / "experiment" / f"{r}.yaml").exists()]
    assert experiment_names()[:13] == list("ABCDEFGHIJKLM")


def test_each_rows_switches_come_from_the_table(monkeypatch):
    """Changing a row in the table changes what ``+experiment=<row>`` composes to, and nothing else does."""
    flipped = {s: not on for s, on in COMPONENTS["B"]["switches"].items()}
    flipped["UN"] = True
    monkeypatch.setitem(methods.COMPONENTS, "B", {**COMPONENTS["B"], "switches": flipped})
    cfg = compose(["+experiment=B"])
    assert cfg.experiment == "B"
    assert {s: cfg.method[s] for s in SWITCHES} == flipped
    default = compose()  # rows share row F's everything but switches
    assert OmegaConf.masked_copy(cfg, [k for k in cfg if k not in ("experiment", "method")]) == \
        OmegaConf.masked_copy(default, [k for k in default if k not in ("experiment", "method")])
    rest = {k: v for k, v in cfg.method.items() if k not in SWITCHES}
    assert rest == {k: v for k, v in default.method.items() if k not in SWITCHES}


@pytest.mark.slow
def test_every_hydra_command_and_a_joblib_multirun_compose_rows_from_the_table(tmp_path):
    """``python -m mcd.plan -m +experiment=A,...,M hydra/launcher=joblib`` (a real multirun in worker
    processes, from a folder outside the checkout) records each row's switches as the table has them; the
    other Hydra commands print them too."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
    rows = ",".join(COMPONENTS)
    subprocess.run([sys.executable, "-m", "mcd.plan", "-m", f"+experiment={rows}", "plan.measure=false",
                    "hydra/launcher=joblib", "hydra.launcher.n_jobs=2", f"hydra.sweep.dir={tmp_path / 'sw'}",
                    f"paths.data_dir={tmp_path / 'data'}"], check=True, cwd=tmp_path, env=env,
                   capture_output=True, text=True)
    for job, row in enumerate(COMPONENTS):
        saved = OmegaConf.load(tmp_path / "sw" / str(job) / ".hydra" / "config.yaml")
        assert saved.experiment == row
        assert {s: saved.method[s] for s in SWITCHES} == COMPONENTS[row]["switches"], row
    for command in ("mcd.run", "mcd.render", "mcd.data.pack", "mcd.tools.check_paths"):
        out = subprocess.run([sys.executable, "-m", command, "+experiment=K", "--cfg", "job"], check=True,
                             cwd=tmp_path, env=env, capture_output=True, text=True).stdout
        printed = OmegaConf.create(out)
        assert {s: printed.method[s] for s in SWITCHES} == COMPONENTS["K"]["switches"], command


@pytest.mark.parametrize("row", ["C", "M"])
def test_the_denoise_command_knows_the_rows(row):
    from mcd.denoise.configs import check_experiment

    check_experiment(row)
    with pytest.raises(ValueError, match=r"--experiment=Z: no such experiment.*choose one of A, B, C"):
        check_experiment("Z")

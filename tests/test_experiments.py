"""Rows A-M of the component study are the files ``conf/experiment/A.yaml`` .. ``M.yaml``, the one place each
row's switches are written (:func:`mcd.config.methods.row_switches` reads them into
:data:`mcd.config.methods.COMPONENTS`, beside the paper's numbers): each is the default config (row F) with
the row's switches and nothing else; every way a config is composed (``compose``, the Hydra commands,
``mcd-denoise --experiment``) reads them as it reads every experiment file (docs/architecture.md, "Config").
The switches are held to the paper by tests/lit/test_switches.py (docs/method.md's rows) and by each row's
size under the ``paper`` profile (tests/models/test_complexity.py)."""

from __future__ import annotations

import pytest
from omegaconf import OmegaConf

from mcd.config import methods
from mcd.config.compose import compose, experiment_names
from mcd.config.methods import COMPONENTS, row_switches

SIX = "UN: true, AS: true, KP: true, PP: false, FG: false, SA: false"


@pytest.mark.parametrize("text", ["experiment: C\nmethod:\n  UN: true\n  AS: true\n",  # two of six
                                  f"experiment: C\nmethod: {{{SIX.replace('AS: true', 'AS: 1')}}}\n",
                                  f"experiment: C\nmethod: {{{SIX}, colour: none}}\n"])
def test_a_row_file_without_exactly_its_six_switches_is_named(text, tmp_path, monkeypatch):
    (tmp_path / "experiment").mkdir()
    (tmp_path / "experiment" / "C.yaml").write_text(text)
    monkeypatch.setattr(methods, "CONF_DIR", tmp_path)
    with pytest.raises(ValueError, match=r"experiment/C.yaml: a component row's file sets "
                                         r"method.\{UN,AS,KP,PP,FG,SA\} to true or false"):
        row_switches("C")


@pytest.mark.slow
def test_the_rows_come_first_and_are_the_default_config_with_their_switches():
    """``+experiment=<row>`` composes to the default config (row F) with ``experiment`` and the six switches
    set, byte for byte as ``--cfg job`` prints it: rows share row F's everything but switches."""
    assert experiment_names()[:13] == list("ABCDEFGHIJKLM") == list(COMPONENTS)
    default = compose()
    for row, paper in COMPONENTS.items():
        expected = OmegaConf.merge(default, {"experiment": row, "method": paper["switches"]})
        assert OmegaConf.to_yaml(compose([f"+experiment={row}"])) == OmegaConf.to_yaml(expected), row


@pytest.mark.parametrize("row", ["C", "M"])
def test_the_denoise_command_knows_the_rows(row):
    from mcd.denoise.configs import check_experiment

    check_experiment(row)
    with pytest.raises(ValueError, match=r"--experiment=Z: no such experiment.*choose one of A, B, C"):
        check_experiment("Z")

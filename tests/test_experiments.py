"""Rows A-M of the component study are the files ``conf/experiment/A.yaml`` .. ``M.yaml``, each written as
:func:`row_file` makes it from the paper's table (:data:`mcd.config.methods.COMPONENTS`): the default
config (row F) with the row's switches and nothing else; every way a config is composed (``compose``, the
Hydra commands, ``mcd-denoise --experiment``) reads them as it reads every experiment file
(docs/architecture.md, "Config")."""

from __future__ import annotations

import pytest
from omegaconf import OmegaConf

from mcd.config.compose import compose, experiment_names
from mcd.config.methods import COMPONENTS
from mcd.core.paths import CONF_DIR
from mcd.models.switches import SWITCHES


def row_file(row: str) -> str:
    """The text of ``conf/experiment/<row>.yaml`` for component row ``row``, from the table alone."""
    switches = COMPONENTS[row]["switches"]
    bits = "".join("1" if switches[s] else "0" for s in SWITCHES)
    return "\n".join([
        "# @package _global_",
        f"# Component row {row} ({bits}) of the paper's study (Sec. 5.3; docs/method.md \"Component",
        "# study\"): the default two-stage method (conf/method/two_stage.yaml, row F) with these switches.",
        "# Its paper numbers: mcd/config/methods.py (COMPONENTS), which tests/test_experiments.py holds this",
        "# file to.",
        f"experiment: {row}",
        "method:",
        *(f"  {s}: {str(switches[s]).lower()}" for s in SWITCHES)]) + "\n"


@pytest.mark.parametrize("row", list(COMPONENTS))
def test_each_rows_file_is_the_tables_row(row):
    path = CONF_DIR / "experiment" / f"{row}.yaml"
    assert path.is_file(), f"write {path}:\n{row_file(row)}"
    assert path.read_text() == row_file(row), f"{path} differs from mcd/config/methods.py's row; write:\n" \
        f"{row_file(row)}"


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

"""The component switches and the experiments A-M (docs/method.md "The five switches")."""

import pytest
from omegaconf import OmegaConf

from mcd.core.paths import CONF_DIR
from mcd.models.switches import check_switches, switch_row

#: The paper's rows as docs/method.md prints them: an oracle apart from the experiment files and the table of
#: mcd/config/methods.py.
ROWS = dict(A="100000", B="110000", C="111000", D="111100", E="111110", F="111111", G="111010", H="111011",
            I="111101", J="111001", K="110100", L="110010", M="110001")


@pytest.mark.parametrize("name", sorted(ROWS))
def test_experiments_hold_method_md_rows(name):
    cfg = OmegaConf.to_container(OmegaConf.load(CONF_DIR / "experiment" / f"{name}.yaml"))
    assert cfg["experiment"] == name and "defaults" not in cfg  # the default method group: two_stage
    assert switch_row(cfg["method"]) == ROWS[name]
    check_switches(cfg["method"])


@pytest.mark.parametrize("key", ["KP", "FG"])
def test_kp_or_fg_without_as_fails_and_says_why(key):
    method = {"name": "two_stage", "UN": True, "AS": False, "KP": False, "PP": False, "FG": False,
              "SA": False}
    method[key] = True
    with pytest.raises(ValueError, match=f"method.{key}=true needs method.AS=true: .*F_s"):
        check_switches(method)


def test_switches_must_be_booleans_and_un_stays_on():
    with pytest.raises(ValueError, match="method.SA must be true or false"):
        check_switches({"SA": "yes"})
    with pytest.raises(ValueError, match="method.UN=false"):
        check_switches({"name": "two_stage", "UN": False, "AS": True})
    check_switches({"name": "rae"})  # a baseline without switches

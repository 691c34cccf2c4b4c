"""The method catalogue (mcd/config/methods.py) agrees with the configs and the model registry: the
``method.name`` and ``trainable`` each entry reads from the config files without composing are what its
experiment composes to, the registry holds the method, and every experiment that is not a component row has
an entry, so tables, the bench and the reports cannot miss a method."""

from __future__ import annotations

import pytest

from mcd.config.compose import compose, experiment_names
from mcd.config.methods import (
    BY_EXPERIMENT,
    CATALOGUE,
    COMPONENTS,
    TABLE1,
    TABLE1_ROWS,
    TABLE1_VARIANTS,
    display_name,
)
from mcd.models import METHODS


@pytest.mark.parametrize("entry", CATALOGUE, ids=lambda m: m.experiment)
def test_each_entry_composes_to_its_method(entry):
    cfg = compose([f"+experiment={entry.experiment}"])
    assert cfg.method.name == entry.method
    assert cfg.method.get("trainable", True) is entry.trainable
    assert entry.method in METHODS.names()


def test_every_experiment_that_is_not_a_component_row_has_an_entry():
    experiments = set(experiment_names())
    others = experiments - set(COMPONENTS)
    assert others <= set(BY_EXPERIMENT), f"add {sorted(others - set(BY_EXPERIMENT))} to mcd/config/methods.py"
    assert set(BY_EXPERIMENT) <= experiments


def test_derived_views_follow_the_entries():
    assert TABLE1_ROWS[:6] == ("unet", "fastdvdnet", "rae", "dasr", "ntasad", "F")  # the paper's order
    assert all(BY_EXPERIMENT[row].table1 for row in TABLE1_VARIANTS.values())
    assert TABLE1["two_stage"] == BY_EXPERIMENT["F"].paper
    assert display_name("F") == "Ours (F)" and display_name("B") == "B"
    for entry in CATALOGUE:
        if entry.stand_in is not None:
            stand_in = compose([f"+experiment={entry.stand_in}"])
            assert stand_in.method.name in ("two_stage", entry.method)

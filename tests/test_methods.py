"""The method catalogue (mcd/config/methods.py, its entries beside each factory) agrees with the configs and
the model registry: each entry sits in the module of the factory its experiment builds, the
``method.name`` and ``trainable`` each entry reads from the config files without composing are what its
experiment composes to, the registry holds the method, and every experiment that is not a component row has
an entry, so tables, the bench and the reports cannot miss a method."""

from __future__ import annotations

import importlib
import inspect
import re
from pathlib import Path

import pytest

from mcd.config.compose import compose, experiment_names
from mcd.config.methods import (
    BY_EXPERIMENT,
    CATALOGUE,
    COMPONENTS,
    FACTORY_MODULES,
    MODELS_DIR,
    TABLE1,
    TABLE1_ROWS,
    TABLE1_VARIANTS,
    display_name,
    entries_assignment,
    module_entries,
)
from mcd.models import METHODS


@pytest.mark.parametrize("entry", CATALOGUE, ids=lambda m: m.experiment)
def test_each_entry_composes_to_its_method(entry):
    cfg = compose([f"+experiment={entry.experiment}"])
    assert cfg.method.name == entry.method
    assert cfg.method.get("trainable", True) is entry.trainable
    assert entry.method in METHODS.names()


@pytest.mark.parametrize("module", FACTORY_MODULES)
def test_each_entry_sits_beside_the_factory_it_builds(module):
    """The entries read from a factory's file are that module's ``ENTRIES``, and the method each one's
    experiment composes to is registered by a factory of that module."""
    imported = importlib.import_module("mcd.models." + module.removesuffix(".py").replace("/", "."))
    assert Path(inspect.getfile(imported)) == MODELS_DIR / module
    entries = [m for m in CATALOGUE if m.experiment in {e["experiment"] for e in imported.ENTRIES}]
    assert len(entries) == len(imported.ENTRIES) >= 1
    for entry in entries:
        assert METHODS.get(entry.method).__module__ == imported.__name__, entry


def test_every_module_that_declares_entries_is_listed():
    """A factory's module with ``ENTRIES`` outside :data:`FACTORY_MODULES` would be left out of the catalogue
    without a word; every module that declares them is listed, and every registered factory's module too."""
    declaring = {p.relative_to(MODELS_DIR).as_posix() for p in MODELS_DIR.rglob("*.py")
                 if entries_assignment(p) is not None}
    factories = {Path(inspect.getfile(METHODS.get(name))).relative_to(MODELS_DIR).as_posix()
                 for name in METHODS.names()}
    assert declaring == factories == set(FACTORY_MODULES), "list each factory's module in FACTORY_MODULES"
    assert len(FACTORY_MODULES) == len(set(FACTORY_MODULES))


def test_a_module_whose_entries_are_not_literal_is_named(tmp_path):
    bad = tmp_path / "factory.py"
    bad.write_text("ENTRIES = ({'experiment': 'x', 'display': 'X', 'colour': 'red'},)\n")
    with pytest.raises(ValueError, match=re.escape(f"{bad}: its ENTRIES are a tuple of literal dicts")):
        module_entries(bad)
    bad.write_text("ENTRIES = tuple(make())\n")
    with pytest.raises(ValueError, match="literal dicts"):
        module_entries(bad)
    bad.write_text("OTHER = ()\n")
    with pytest.raises(ValueError, match="no module-level ENTRIES"):
        module_entries(bad)


def test_every_experiment_that_is_not_a_component_row_has_an_entry():
    experiments = set(experiment_names())
    others = experiments - set(COMPONENTS)
    missing = sorted(others - set(BY_EXPERIMENT))
    assert not missing, f"add {missing} to the ENTRIES beside their factory (mcd.config.methods)"
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

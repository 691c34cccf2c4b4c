"""One place per method, one value per setting (docs/architecture.md "Methods"): a method factory's signature
is its knob list, every knob is given by its config files (``conf/method/<name>.yaml`` and its entry of the
capacity profiles, ``conf/capacity/``) and nothing else is, a knob with a default has the default the files
give it (so that a factory called by hand builds what a run builds), and every method is in the catalogue."""

from __future__ import annotations

import inspect

import pytest

from mcd.config.compose import compose
from mcd.config.methods import CATALOGUE
from mcd.core.paths import CONF_DIR
from mcd.models.registry import METHODS, capacity_entry, factory_kwargs

NAMES = sorted(p.stem for p in (CONF_DIR / "method").glob("*.yaml"))


def disagreements(name: str, capacity: str) -> list[str]:
    """``key: default != config`` for each knob of method ``name``'s factory whose default differs from the
    value its config files (under the capacity profile ``capacity``) give it."""
    kwargs = factory_kwargs(compose([f"method={name}", f"capacity={capacity}"]))
    params = inspect.signature(METHODS.get(name)).parameters
    return [f"{k}: {p.default!r} != {kwargs[k]!r}" for k, p in params.items()
            if p.default is not inspect.Parameter.empty and k in kwargs and p.default != kwargs[k]]


@pytest.mark.parametrize("capacity", ["cpu", "paper"])
@pytest.mark.parametrize("name", NAMES)
def test_every_factory_default_is_the_configs_value(name, capacity):
    assert disagreements(name, capacity) == [], f"conf/method/{name}.yaml and its factory disagree"


def test_the_check_finds_a_default_the_config_does_not_give(monkeypatch):
    def build_two_stage_direct(*, denoiser_output: str = "direct", **kwargs):
        raise AssertionError("not called")

    METHODS.get("two_stage")  # the built-in methods registered first
    monkeypatch.setitem(METHODS._entries, "two_stage", build_two_stage_direct)
    assert disagreements("two_stage", "cpu") == ["denoiser_output: 'direct' != 'residual'"]


@pytest.mark.parametrize("capacity", ["cpu", "paper"])
@pytest.mark.parametrize("name", NAMES)
def test_each_methods_knobs_are_its_files_keys_and_it_is_catalogued(name, capacity):
    cfg = compose([f"method={name}", f"capacity={capacity}"])
    params = inspect.signature(METHODS.get(name)).parameters
    if not any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        assert set(params) == set(factory_kwargs(cfg)), f"conf/method/{name}.yaml and its factory's knobs"
    assert (capacity_entry(name) in cfg.capacity) == bool(cfg.method.get("trainable", True))
    assert [m.experiment for m in CATALOGUE if m.method == name], f"add {name} to its factory's ENTRIES"

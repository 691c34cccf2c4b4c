"""One value per setting (docs/architecture.md "Models"): a method factory's signature is its knob list, and
a knob with a default has the default its config files give it (``conf/method/<name>.yaml`` and the
capacity profiles, ``conf/capacity/``), so that a factory called by hand builds what a run builds."""

from __future__ import annotations

import inspect

import pytest

from mcd.config.compose import compose
from mcd.core.paths import CONF_DIR
from mcd.models.registry import METHODS, factory_kwargs

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

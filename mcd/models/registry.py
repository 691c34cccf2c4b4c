"""Method registry: ``@register(name)`` on a factory ``cfg -> nn.Module``; :func:`build` picks one by name.

Factories read ``cfg.method`` (name and switches), ``cfg.budget`` and their widths from ``cfg.model.<name>``.
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Callable

from torch import nn

Factory = Callable[..., nn.Module]
REGISTRY: dict[str, Factory] = {}

#: Modules whose import registers the built-in methods.
BUILTIN_MODULES = ("mcd.models.two_stage", "mcd.models.baselines")


def register(name: str) -> Callable[[Factory], Factory]:
    """Decorator: register ``factory(cfg) -> nn.Module`` under ``name`` (a name may be registered once)."""

    def deco(factory: Factory) -> Factory:
        if name in REGISTRY and REGISTRY[name] is not factory:
            raise ValueError(f"method {name!r} is registered twice ({REGISTRY[name]} and {factory})")
        REGISTRY[name] = factory
        return factory

    return deco


def load_builtin(until: str | None = None) -> None:
    """Import the modules that register the built-in methods, stopping once ``until`` is registered."""
    for module in BUILTIN_MODULES:
        if until is not None and until in REGISTRY:
            return
        if importlib.util.find_spec(module) is not None:
            importlib.import_module(module)


def build(cfg) -> nn.Module:
    """The model named by ``cfg.method.name``, built from ``cfg`` (raises ``KeyError`` naming the choices)."""
    name = cfg.method.name
    load_builtin(until=name)
    if name not in REGISTRY:
        raise KeyError(f"unknown method.name {name!r}; registered methods: {sorted(REGISTRY)}")
    return REGISTRY[name](cfg)

"""The methods by name (``method.name``): :data:`METHODS`, a :class:`mcd.core.registry.Registry` (after
BasicSR's: ``METHODS.get(name)(**kwargs)``).

A method registers ``@register(name)`` (``mcd.models.register``) on a factory that takes plain keyword
arguments, so that its signature is its knob list: ``budget`` (average samples per pixel), the settings of
its ``conf/method/<name>.yaml`` (less :data:`RUN_KEYS`, which the run reads) and the keys of its entry in the
capacity profile (``conf/capacity/<profile>.yaml``: ``capacity.<name>``, or the entry it names when it
registers, ``register(name, capacity=<entry>)``); a knob's default, where it has one, is the YAML's
(docs/architecture.md, "Methods"). :func:`build` is the one place that turns a run's config into those
arguments (:func:`factory_kwargs`); a key the factory does not take, or one it needs that the config lacks,
is refused naming the key and the factory's settings (docs/architecture.md, "Models").
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from typing import Any

from omegaconf import DictConfig, OmegaConf
from torch import nn

from mcd.core.registry import Registry
from mcd.models.margin import set_margin
from mcd.models.output_steps import attach_output_steps

Factory = Callable[..., nn.Module]

#: Every method; importing ``mcd.models.two_stage`` and ``mcd.models.baselines`` registers the built-in ones.
METHODS: Registry[Factory] = Registry("method", ("mcd.models.two_stage", "mcd.models.baselines"))
#: Method -> the capacity profile's entry it reads where that is not its own name, as its module registers it
#: (the U-Net is row A and reads ``capacity.two_stage``: docs/baselines.md "U-Net").
_CAPACITY_ENTRY: dict[str, str] = {}


def register(name: str, *, capacity: str | None = None) -> Callable[[Factory], Factory]:
    """Decorator: register method ``name``'s factory in :data:`METHODS`; ``capacity``: the capacity
    profile's entry its widths come from, where that is not ``capacity.<name>``."""
    if capacity is not None:
        _CAPACITY_ENTRY[name] = capacity
    return METHODS.register(name)


def capacity_entry(name: str) -> str:
    """The capacity profile's entry method ``name`` reads (``capacity.<entry>``)."""
    METHODS.get(name)  # its module imported, so that its registration is known
    return _CAPACITY_ENTRY.get(name, name)

#: Keys of a method's section that the run reads, not its factory: its name, whether it trains, and what
#: :func:`build` adds to every method: the output steps (mcd/models/output_steps.py) and the denoiser's margin
#: outside training (mcd/models/margin.py).
RUN_KEYS = ("name", "trainable", "mean_match", "output_bound", "pass_misses", "denoiser_margin")


def factory_kwargs(cfg: DictConfig) -> dict[str, Any]:
    """The keyword arguments of ``cfg.method.name``'s factory: ``budget``, the method's settings less
    :data:`RUN_KEYS`, and the keys of its capacity entry (absent for a method without widths), as plain
    Python values. ValueError naming a key that both sections set."""
    method = OmegaConf.to_container(cfg.method, resolve=True)
    assert isinstance(method, dict)
    name = str(method["name"])
    kwargs: dict[str, Any] = {k: v for k, v in method.items() if k not in RUN_KEYS}
    entry = capacity_entry(name)
    capacity = cfg.get("capacity")
    widths = capacity.get(entry) if capacity is not None else None
    if widths is not None:
        sizes = OmegaConf.to_container(widths, resolve=True)
        assert isinstance(sizes, dict)
        both = sorted(set(sizes) & set(kwargs))
        if both:
            raise ValueError(f"method.{both[0]} and capacity.{entry}.{both[0]} both set {both[0]!r} of "
                             f"method {name}: keep it in one of them")
        kwargs.update(sizes)
    return {"budget": float(cfg.budget), **kwargs}


def check_call(name: str, factory: Factory, kwargs: dict[str, Any]) -> None:
    """ValueError naming a setting method ``name``'s ``factory`` does not take, or one it needs and did not
    get (a factory with ``**kwargs`` checks its own)."""
    params = inspect.signature(factory).parameters
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in params.values()):
        return
    entry = capacity_entry(name)
    unknown = sorted(set(kwargs) - set(params))
    if unknown:
        raise ValueError(f"method.{unknown[0]} (or capacity.{entry}.{unknown[0]}): not a setting of method "
                         f"{name}; its settings: {', '.join(params)}")
    missing = [k for k, p in params.items() if p.default is inspect.Parameter.empty and k not in kwargs
               and p.kind is not inspect.Parameter.VAR_POSITIONAL]
    if missing:
        raise ValueError(f"method {name} needs {', '.join(missing)}: set them in method.* (conf/method/{name}"
                         f".yaml) or capacity.{entry}.* (pick a capacity profile that has them, e.g. "
                         "capacity=cpu or capacity=paper, conf/capacity/)")


def build(cfg: DictConfig) -> nn.Module:
    """The model named by ``cfg.method.name``: its factory called with :func:`factory_kwargs`, with the
    denoiser's margin outside training (``method.denoiser_margin``, :func:`mcd.models.margin.set_margin`;
    docs/method.md "Frame edges") and the output steps its method sets (``method.mean_match``,
    ``method.output_bound``, ``method.pass_misses``: :func:`mcd.models.output_steps.attach_output_steps`;
    docs/method.md "Output")."""
    name = str(cfg.method.name)
    factory = METHODS.get(name)
    kwargs = factory_kwargs(cfg)
    check_call(name, factory, kwargs)
    return attach_output_steps(set_margin(factory(**kwargs), cfg.method), cfg.method, float(cfg.budget))

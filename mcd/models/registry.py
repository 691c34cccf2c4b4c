"""The methods by name (``method.name``): :data:`METHODS`, a :class:`mcd.registry.Registry`.

A method registers ``@METHODS.register(name)`` (``mcd.models.register``) on a constructor
``(method, capacity, budget) -> nn.Module`` that takes its own settings: ``method`` the method's config
(the ``conf/method/`` group), ``capacity`` the capacity profile (``conf/capacity/``; the constructor reads
its own entry, ``capacity.<name>``) and ``budget`` the average samples per pixel. :func:`build` is the one
place that hands a run's config to it.
"""

from __future__ import annotations

from collections.abc import Callable

from omegaconf import DictConfig
from torch import nn

from mcd.models.output_steps import attach_output_steps
from mcd.registry import Registry

Factory = Callable[[DictConfig, DictConfig, float], nn.Module]

#: Every method; importing ``mcd.models.two_stage`` and ``mcd.models.baselines`` registers the built-in ones.
METHODS: Registry[Factory] = Registry("method", ("mcd.models.two_stage", "mcd.models.baselines"))
register = METHODS.register


def widths_of(capacity: DictConfig, key: str) -> DictConfig:
    """The capacity profile's entry ``capacity.<key>``; ``KeyError`` naming the key and the profiles."""
    entry = capacity.get(key) if capacity is not None else None
    if entry is None:
        raise KeyError(f"capacity.{key} (the widths of {key}) is missing; pick a capacity profile that has "
                       "it, e.g. capacity=cpu or capacity=paper (conf/capacity/)")
    return entry


def build(cfg: DictConfig) -> nn.Module:
    """The model named by ``cfg.method.name``, from ``cfg.method``, ``cfg.capacity`` and ``cfg.budget``, with
    the output steps its method sets (``method.mean_match``, ``method.pass_misses``:
    :func:`mcd.models.output_steps.attach_output_steps`; docs/method.md "Output")."""
    budget = float(cfg.budget)
    module = METHODS.get(str(cfg.method.name))(cfg.method, cfg.get("capacity"), budget)
    return attach_output_steps(module, cfg.method, budget)

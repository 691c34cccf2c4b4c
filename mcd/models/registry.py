"""The methods by name (``method.name``): :data:`METHODS`, a :class:`mcd.registry.Registry`.

A method registers ``@METHODS.register(name)`` (``mcd.models.register``) on a constructor
``(method, model, budget) -> nn.Module`` that takes its own settings: ``method`` the method's config
(the ``conf/method/`` group), ``model`` the capacity profile (``conf/model/``; the constructor reads its
own entry, ``model.<name>``) and ``budget`` the average samples per pixel. :func:`build` is the one place
that hands a run's config to it.
"""

from __future__ import annotations

from collections.abc import Callable

from omegaconf import DictConfig
from torch import nn

from mcd.models.mean_match import attach_mean_match
from mcd.models.misses import attach_pass_misses
from mcd.registry import Registry

Factory = Callable[[DictConfig, DictConfig, float], nn.Module]

#: Every method; importing ``mcd.models.two_stage`` and ``mcd.models.baselines`` registers the built-in ones.
METHODS: Registry[Factory] = Registry("method", ("mcd.models.two_stage", "mcd.models.baselines"))
register = METHODS.register


def widths_of(model: DictConfig, key: str) -> DictConfig:
    """The capacity profile's entry ``model.<key>``; ``KeyError`` naming the key and the profiles."""
    entry = model.get(key) if model is not None else None
    if entry is None:
        raise KeyError(f"model.{key} (the widths of {key}) is missing; pick a capacity profile that has it, "
                       "e.g. model=cpu or model=paper (conf/model/)")
    return entry


def build(cfg: DictConfig) -> nn.Module:
    """The model named by ``cfg.method.name``, from ``cfg.method``, ``cfg.model`` and ``cfg.budget``, with the
    output steps its method sets (docs/method.md "Output"), in this order: ``method.mean_match`` (the output
    takes the frame mean of the render it denoised; a model whose class sets ``applies_mean_match`` does that
    itself, the others get :func:`mcd.models.mean_match.attach_mean_match`), then ``method.pass_misses``
    (pixels without geometry keep the render's value: :func:`mcd.models.misses.attach_pass_misses`)."""
    budget = float(cfg.budget)
    method = cfg.method
    module = METHODS.get(str(method.name))(method, cfg.get("model"), budget)
    if bool(method.get("mean_match", False)) and not getattr(module, "applies_mean_match", False):
        attach_mean_match(module, budget)
    if bool(method.get("pass_misses", False)):
        attach_pass_misses(module, budget)
    return module

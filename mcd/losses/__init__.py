"""Training losses (docs/method.md "Losses", docs/baselines.md), chosen by ``loss.name`` (``conf/loss/``).

:data:`LOSSES` is a :class:`mcd.core.registry.Registry`; a loss registers ``@LOSSES.register(name)``
(``register_loss``) on a class whose constructor takes the settings of its ``conf/loss/<name>.yaml`` as
keyword arguments (everything but ``name``). The built-in losses are :mod:`mcd.losses.paper` (``paper``) and
:mod:`mcd.losses.baselines` (``rae``, ``dasr``, ``ntasad``, ``mse``). Every loss is an ``nn.Module`` called as
``loss(pred, ref) -> dict`` with ``pred`` and ``ref`` the clip's outputs and references ``[B, T, 3, H, W]``
(linear HDR); the dict holds the total under ``"loss"`` and each term under its own name (logged as
``train/<name>``). It has a ``perceptual_status`` (:class:`mcd.losses.vgg.PerceptualStatus`) and may say how
many of the clip's last outputs it reads (``frames_needed``; absent = all): the training module then computes
only those (docs/training.md, "Throughput").
"""

from __future__ import annotations

from collections.abc import Callable

from omegaconf import DictConfig, OmegaConf
from torch import nn

from mcd.core.registry import Registry

LossFactory = Callable[..., nn.Module]

#: Every loss; importing ``mcd.losses.paper`` and ``mcd.losses.baselines`` registers the built-in ones.
LOSSES: Registry[LossFactory] = Registry("loss", ("mcd.losses.paper", "mcd.losses.baselines"))
register_loss = LOSSES.register

def build_loss(cfg: DictConfig) -> nn.Module:
    """The loss named ``cfg.loss.name``, constructed from the other keys of ``cfg.loss``."""
    settings = OmegaConf.to_container(cfg.loss, resolve=True)
    assert isinstance(settings, dict)
    constructor = LOSSES.get(str(settings["name"]))
    kwargs = {k: v for k, v in settings.items() if k != "name"}
    try:
        return constructor(**kwargs)
    except TypeError as err:
        raise ValueError(f"loss {settings['name']!r}: its settings {sorted(kwargs)} do not fit {constructor} "
                         f"({err}); see conf/loss/{settings['name']}.yaml") from err


__all__ = ["LOSSES", "build_loss", "register_loss"]

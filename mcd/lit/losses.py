"""Training losses, chosen by name (``cfg.loss.name``) from a registry.

The paper's loss (Sec. "Loss functions"; docs/method.md "Losses") is ``L = W_s L_s + W_t L_t + W_p L_p`` with
``W = (0.8, 0.2, 0.1)``: ``L_s`` is the L1 distance of output and reference on the clip's last frame,
``L_t`` the L1 distance of ``d_t - d_{t-1}`` and ``ref_t - ref_{t-1}`` on the last two frames, and ``L_p`` a
VGG-16 feature distance on the last frame (off without a local weights file). All terms are computed in a
compressed colour range (``loss.space``, default ``log1p``).

Every loss is an ``nn.Module`` called as ``loss(pred, ref) -> dict`` with ``pred`` and ``ref`` the clip's
outputs and references ``[B, T, 3, H, W]`` (linear HDR); the dict holds the total under ``"loss"`` and each
term under its own name (logged as ``train/<name>``). It has a ``perceptual_status``
(:class:`PerceptualStatus`) and may say how many of the clip's last outputs it reads (``frames_needed``;
absent = all): the training module then computes only those (docs/training.md, "Throughput").

Other losses (baselines) register themselves with :func:`register_loss` in their own module; a loss config
names that module in ``loss.module`` so that :func:`build_loss` imports it first.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable

import torch
from omegaconf import DictConfig
from torch import Tensor, nn

from mcd.lit.vgg import PerceptualStatus, VGGPerceptual, load_perceptual

LossFactory = Callable[[DictConfig], nn.Module]
LOSSES: dict[str, LossFactory] = {}


def register_loss(name: str) -> Callable[[LossFactory], LossFactory]:
    """Decorator: register ``factory(cfg) -> nn.Module`` (a class or function) as loss ``name``."""

    def deco(factory: LossFactory) -> LossFactory:
        if name in LOSSES and LOSSES[name] is not factory:
            raise ValueError(f"loss {name!r} is registered twice ({LOSSES[name]} and {factory})")
        LOSSES[name] = factory
        return factory

    return deco


def build_loss(cfg: DictConfig) -> nn.Module:
    """The loss named ``cfg.loss.name``, built from the whole config (it reads ``loss.*`` and ``paths.*``)."""
    module = cfg.loss.get("module")
    if module:
        try:
            importlib.import_module(module)
        except ImportError as err:
            raise ValueError(f"loss.module={module!r} (loss {cfg.loss.name!r}) cannot be imported: "
                             f"{err}") from err
    name = cfg.loss.name
    if name not in LOSSES:
        raise ValueError(f"unknown loss.name={name!r}; registered: {sorted(LOSSES)} "
                         "(a loss from another module needs loss.module set to that module)")
    return LOSSES[name](cfg)


def compress(x: Tensor, space: str) -> Tensor:
    """Colour compression for losses: ``log1p`` (odd-symmetric: negatives stay finite) or ``linear``.

    The slope at 0 is 1 (not ``sign``'s or ``abs``'s 0), so an output that is exactly 0, e.g. clamped at
    initialisation, still gets a gradient.
    """
    if space == "log1p":
        return torch.where(x >= 0, torch.log1p(x.clamp_min(0)), -torch.log1p((-x).clamp_min(0)))
    if space == "linear":
        return x
    raise ValueError(f"loss.space must be 'log1p' or 'linear', got {space!r}")


def perceptual_from_cfg(cfg: DictConfig) -> tuple[VGGPerceptual | None, PerceptualStatus]:
    """``L_p``'s network from ``paths.vgg16_weights`` (shared by every loss that uses the perceptual term)."""
    layers = tuple(cfg.loss.get("perceptual_layers", (3, 8, 15, 22)))
    return load_perceptual(cfg.paths.get("vgg16_weights"), layers)


@register_loss("paper")
class PaperLoss(nn.Module):
    """``0.8 L_s + 0.2 L_t + 0.1 L_p`` (weights ``loss.w_s``, ``loss.w_t``, ``loss.w_p``), paper Sec. 4.2."""

    def __init__(self, cfg: DictConfig) -> None:
        super().__init__()
        self.space = str(cfg.loss.space)
        compress(torch.zeros(1), self.space)  # validate early
        self.w_s, self.w_t, self.w_p = float(cfg.loss.w_s), float(cfg.loss.w_t), float(cfg.loss.w_p)
        #: The loss reads the clip's last output (L_s, L_p) and the one before it (L_t): mcd.lit.module runs
        #: only what it needs.
        self.frames_needed = 2 if self.w_t > 0 else 1
        if self.w_p > 0:
            self.vgg, self.perceptual_status = perceptual_from_cfg(cfg)
        else:
            self.vgg, self.perceptual_status = None, PerceptualStatus(False, "loss.w_p is 0")

    def forward(self, pred: Tensor, ref: Tensor) -> dict[str, Tensor]:
        if pred.shape != ref.shape or pred.ndim != 5:
            raise ValueError(f"loss expects pred and ref [B, T, 3, H, W] of one shape, got "
                             f"{tuple(pred.shape)} and {tuple(ref.shape)}")
        if self.w_t > 0 and pred.shape[1] < 2:
            raise ValueError("L_t needs clips of at least 2 frames: raise data.clip_len or set loss.w_t=0")
        p, r = compress(pred.float(), self.space), compress(ref.float(), self.space)
        terms = {"l_s": (p[:, -1] - r[:, -1]).abs().mean()}
        if self.w_t > 0:
            terms["l_t"] = ((p[:, -1] - p[:, -2]) - (r[:, -1] - r[:, -2])).abs().mean()
        if self.vgg is not None:
            terms["l_p"] = self.vgg(p[:, -1], r[:, -1])
        weights = {"l_s": self.w_s, "l_t": self.w_t, "l_p": self.w_p}
        terms["loss"] = sum(weights[k] * v for k, v in terms.items())
        return terms

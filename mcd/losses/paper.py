"""The paper's loss (Sec. "Loss functions"; docs/method.md "Losses"), registered as ``paper``.

``L = W_s L_s + W_t L_t + W_p L_p`` with ``W = (0.8, 0.2, 0.1)``: ``L_s`` is the L1 distance of output and
reference on the clip's last frame, ``L_t`` the L1 distance of ``d_t - d_{t-1}`` and ``ref_t - ref_{t-1}`` on
the last two frames, and ``L_p`` a VGG-16 feature distance on the last frame (off without a local weights
file). All terms are computed in a compressed colour range (``loss.space``, default ``log1p``). The calling
convention of every loss: :mod:`mcd.losses`.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import Tensor, nn

from mcd.losses import register_loss
from mcd.losses.vgg import DEFAULT_LAYERS, PerceptualStatus, load_perceptual


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


@register_loss("paper")
class PaperLoss(nn.Module):
    """``0.8 L_s + 0.2 L_t + 0.1 L_p`` (weights ``w_s``, ``w_t``, ``w_p``: conf/loss/paper.yaml), paper
    Sec. 4.2.

    ``L_p`` reads the VGG-16 weights file ``vgg16_weights`` (``paths.vgg16_weights``; ``None``: ``L_p``
    off)."""

    def __init__(self, space: str, w_s: float, w_t: float, w_p: float,
                 perceptual_layers: Sequence[int] = DEFAULT_LAYERS,
                 vgg16_weights: str | None = None) -> None:
        super().__init__()
        self.space = str(space)
        compress(torch.zeros(1), self.space)  # validate early
        self.w_s, self.w_t, self.w_p = float(w_s), float(w_t), float(w_p)
        #: The loss reads the clip's last output (L_s, L_p) and the one before it (L_t): mcd.lit.module runs
        #: only what it needs.
        self.frames_needed = 2 if self.w_t > 0 else 1
        if self.w_p > 0:
            self.vgg, self.perceptual_status = load_perceptual(vgg16_weights, tuple(perceptual_layers))
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

"""The baselines' own training losses (docs/baselines.md), registered in :data:`mcd.losses.LOSSES` by name.

Select one with ``loss=<name>`` (``conf/loss/<name>.yaml``, whose keys are the constructor's arguments); the
paper's loss (``loss=paper``) is the alternative the paper itself used for every method. Like the paper's
loss, each is called as ``loss(pred, ref) -> dict`` on ``[B, T, 3, H, W]`` linear HDR clips and computes its
terms in ``loss.space`` (default ``log1p``). None has a perceptual term.

- ``rae`` (Chaitanya et al. 2017): per frame ``w_s L1 + w_g L1(LoG) + w_t L1(temporal difference)`` with
  per-frame weights ``[0.135, 0.325, 0.607, 0.882, 1]`` over the clip (the last ``T`` of them).
- ``dasr`` (Kuznetsov et al. 2018): relative L1 (``eps`` 0.01) + relative L1 of Laplacian-of-Gaussian images.
- ``ntasad`` (Hasselgren et al. 2020): L1 + temporal L1 over the unrolled clip.
- ``mse``: FastDVDnet's original mean squared error.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from mcd.losses import register_loss
from mcd.losses.paper import compress
from mcd.losses.vgg import PerceptualStatus


def check_clip(pred: Tensor, ref: Tensor, name: str, min_frames: int = 1) -> None:
    if pred.shape != ref.shape or pred.ndim != 5:
        raise ValueError(f"loss {name!r} expects pred and ref [B, T, 3, H, W] of one shape, got "
                         f"{tuple(pred.shape)} and {tuple(ref.shape)}")
    if pred.shape[1] < min_frames:
        raise ValueError(f"loss {name!r} needs clips of at least {min_frames} frames (its temporal term); "
                         f"got T={pred.shape[1]}: raise data.clip_len or set the temporal weight to 0")


def log_kernel(sigma: float) -> Tensor:
    """Zero-sum Laplacian-of-Gaussian kernel, ``2 ceil(3 sigma) + 1`` taps square."""
    r = math.ceil(3 * sigma)
    ax = torch.arange(-r, r + 1, dtype=torch.float32)
    d2 = ax[None, :] ** 2 + ax[:, None] ** 2
    k = -(1 - d2 / (2 * sigma**2)) * torch.exp(-d2 / (2 * sigma**2)) / (math.pi * sigma**4)
    return k - k.mean()


class LoG(nn.Module):
    """Laplacian-of-Gaussian filter per channel of ``[N, C, H, W]`` (replicate padding)."""

    def __init__(self, sigma: float) -> None:
        super().__init__()
        self.register_buffer("kernel", log_kernel(sigma)[None, None], persistent=False)

    def forward(self, x: Tensor) -> Tensor:
        n, c, h, w = x.shape
        r = self.kernel.shape[-1] // 2
        y = F.pad(x.reshape(n * c, 1, h, w), (r, r, r, r), mode="replicate")
        return F.conv2d(y, self.kernel.to(x.dtype)).reshape(n, c, h, w)


class BaselineLoss(nn.Module):
    """Common part: colour space, no perceptual term."""

    name = ""

    def __init__(self, space: str) -> None:
        super().__init__()
        self.space = str(space)
        compress(torch.zeros(1), self.space)  # validate early
        self.perceptual_status = PerceptualStatus(False, f"loss {self.name!r} (the method's own loss) has no "
                                                         "perceptual term; loss=paper has it")

    def prepare(self, pred: Tensor, ref: Tensor, min_frames: int = 1) -> tuple[Tensor, Tensor]:
        check_clip(pred, ref, self.name, min_frames)
        return compress(pred.float(), self.space), compress(ref.float(), self.space)


def temporal_l1(p: Tensor, r: Tensor) -> Tensor:
    """``|(p_t - p_{t-1}) - (r_t - r_{t-1})|`` per frame pair, ``[B, T-1, ...]``."""
    return ((p[:, 1:] - p[:, :-1]) - (r[:, 1:] - r[:, :-1])).abs()


@register_loss("rae")
class RAELoss(BaselineLoss):
    """RAE's loss (docs/baselines.md "RAE"): ``w_s`` L1 + ``w_g`` L1 of LoG(``sigma``) + ``w_t`` temporal L1,
    each frame weighted by ``frame_weights`` (the last ``T``; the temporal term from the clip's second
    frame)."""

    name = "rae"

    def __init__(self, space: str, w_s: float, w_g: float, w_t: float, sigma: float,
                 frame_weights: Sequence[float]) -> None:
        super().__init__(space)
        self.w_s, self.w_g, self.w_t = float(w_s), float(w_g), float(w_t)
        self.frame_weights = [float(w) for w in frame_weights]
        self.log = LoG(float(sigma))

    def forward(self, pred: Tensor, ref: Tensor) -> dict[str, Tensor]:
        p, r = self.prepare(pred, ref, 2 if self.w_t > 0 else 1)
        b, t = p.shape[:2]
        if t > len(self.frame_weights):
            raise ValueError(f"loss 'rae' has {len(self.frame_weights)} loss.frame_weights for a clip of {t} "
                             "frames: give one weight per frame")
        wf = p.new_tensor(self.frame_weights[-t:])
        l1 = (p - r).abs().mean((2, 3, 4))  # [B, T]
        lg = (self.log(p.flatten(0, 1)) - self.log(r.flatten(0, 1))).abs().mean((1, 2, 3)).view(b, t)
        terms = {"l1": (l1 * wf).sum(1).mean() / wf.sum(), "l_log": (lg * wf).sum(1).mean() / wf.sum()}
        if self.w_t > 0:
            lt = temporal_l1(p, r).mean((2, 3, 4))
            terms["l_t"] = (lt * wf[1:]).sum(1).mean() / wf[1:].sum()
        terms["loss"] = self.w_s * terms["l1"] + self.w_g * terms["l_log"] + self.w_t * terms.get("l_t", 0.0)
        return terms


@register_loss("dasr")
class DASRLoss(BaselineLoss):
    """DASR's loss (docs/baselines.md "DASR"): relative L1 ``|p - r| / (|r| + eps)`` + ``w_g`` times the same
    on
    LoG(``sigma``) images, over every frame of the clip (DASR is single-frame)."""

    name = "dasr"

    def __init__(self, space: str, eps: float, w_g: float, sigma: float) -> None:
        super().__init__(space)
        self.eps, self.w_g = float(eps), float(w_g)
        self.log = LoG(float(sigma))

    def rel_l1(self, p: Tensor, r: Tensor) -> Tensor:
        return ((p - r).abs() / (r.abs() + self.eps)).mean()

    def forward(self, pred: Tensor, ref: Tensor) -> dict[str, Tensor]:
        p, r = (v.flatten(0, 1) for v in self.prepare(pred, ref))
        terms = {"rel_l1": self.rel_l1(p, r), "rel_l1_log": self.rel_l1(self.log(p), self.log(r))}
        terms["loss"] = terms["rel_l1"] + self.w_g * terms["rel_l1_log"]
        return terms


@register_loss("ntasad")
class NTASADLoss(BaselineLoss):
    """NTASAD's loss (docs/baselines.md "NTASAD"): ``w_s`` L1 over all frames + ``w_t`` temporal L1 over the
    unroll."""

    name = "ntasad"

    def __init__(self, space: str, w_s: float, w_t: float) -> None:
        super().__init__(space)
        self.w_s, self.w_t = float(w_s), float(w_t)

    def forward(self, pred: Tensor, ref: Tensor) -> dict[str, Tensor]:
        p, r = self.prepare(pred, ref, 2 if self.w_t > 0 else 1)
        terms = {"l1": (p - r).abs().mean()}
        if self.w_t > 0:
            terms["l_t"] = temporal_l1(p, r).mean()
        terms["loss"] = self.w_s * terms["l1"] + self.w_t * terms.get("l_t", 0.0)
        return terms


@register_loss("mse")
class MSELoss(BaselineLoss):
    """FastDVDnet's original loss (docs/baselines.md "FastDVDnet"): mean squared error over every frame."""

    name = "mse"

    def forward(self, pred: Tensor, ref: Tensor) -> dict[str, Tensor]:
        p, r = self.prepare(pred, ref)
        mse = (p - r).square().mean()
        return {"mse": mse, "loss": mse}

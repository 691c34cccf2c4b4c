"""Semantic alignment (paper Sec. 4.2 "Semantic Alignment"; docs/method.md "Semantic alignment").

At the denoiser's deepest level: the query is the current features plus a 2-D sine-cosine positional encoding;
key and value are the previous frame's attended features, kept from the last call (the first frame after
:meth:`reset` attends to itself). Multi-head attention + residual, then a 2-D feed-forward block
(1x1 conv - ReLU - 1x1 conv) + residual. The output is kept for the next frame *without* detaching, so a
5-frame training clip back-propagates through time; call :meth:`reset` at every clip / sequence start.
The reference runs the attention in fp32 whatever the autocast state. Fast path (:mod:`mcd.models.fast_paths`,
docs/inference.md "Fast paths"): under autocast the projections and ``scaled_dot_product_attention`` run in
the autocast dtype (its fused kernels keep the softmax's running maximum and sum in fp32), the residual sums
in fp32.
"""

from __future__ import annotations

import math
from contextlib import nullcontext

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from mcd.core.stages import stage
from mcd.models import fast_paths


def sine_cosine_encoding(channels: int, h: int, w: int, device: torch.device) -> Tensor:
    """2-D sine-cosine positional encoding ``[1, channels, h, w]`` (half the channels for y, half for x)."""
    if channels % 4:
        raise ValueError(f"the 2-D sine-cosine encoding needs channels divisible by 4; got {channels}")
    quarter = channels // 4
    freq = torch.exp(-math.log(10000.0) * torch.arange(quarter, device=device, dtype=torch.float32) / quarter)
    ys = torch.arange(h, device=device, dtype=torch.float32)[:, None] * freq          # [h, q]
    xs = torch.arange(w, device=device, dtype=torch.float32)[:, None] * freq          # [w, q]
    ey = torch.cat([ys.sin(), ys.cos()], 1).T[:, :, None].expand(-1, h, w)
    ex = torch.cat([xs.sin(), xs.cos()], 1).T[:, None, :].expand(-1, h, w)
    return torch.cat([ey, ex], 0)[None]


class SemanticAlignment(nn.Module):
    """Transformer-style alignment of the current frame's features to the previous frame's, with state."""

    def __init__(self, channels: int, heads: int = 4, ffn_mult: int = 2) -> None:
        super().__init__()
        if channels % heads:
            raise ValueError(f"semantic alignment: {channels} channels do not split into {heads} heads")
        self.heads = heads
        self.q = nn.Linear(channels, channels)
        self.k = nn.Linear(channels, channels)
        self.v = nn.Linear(channels, channels)
        self.out = nn.Linear(channels, channels)
        self.ffn = nn.Sequential(nn.Conv2d(channels, channels * ffn_mult, 1), nn.ReLU(inplace=True),
                                 nn.Conv2d(channels * ffn_mult, channels, 1))
        self.prev: Tensor | None = None

    def reset(self) -> None:
        """Forget the previous frame (start of a clip or sequence)."""
        self.prev = None

    @stage("SA")
    def forward(self, x: Tensor) -> Tensor:
        b, c, h, w = x.shape
        memory = x if self.prev is None else self.prev
        if memory.shape != x.shape:
            raise RuntimeError(f"semantic alignment kept features of shape {tuple(memory.shape)} from the "
                               f"previous frame but got {tuple(x.shape)}; call model.reset() at each "
                               "clip/sequence start")
        half = not x.is_meta and fast_paths.enabled() and torch.is_autocast_enabled(x.device.type)
        no_autocast = nullcontext() if x.is_meta or half else torch.autocast(x.device.type, enabled=False)
        with no_autocast:
            xf = x.float()
            query = (xf + sine_cosine_encoding(c, h, w, x.device)).flatten(2).transpose(1, 2)   # [B, L, C]
            mem = memory.float().flatten(2).transpose(1, 2)
            q, k, v = (self._split(p(t)) for p, t in ((self.q, query), (self.k, mem), (self.v, mem)))
            att = F.scaled_dot_product_attention(q, k, v)                          # [B, heads, L, d]
            att = self.out(att.transpose(1, 2).reshape(b, h * w, c)).transpose(1, 2).reshape(b, c, h, w)
            y = xf + att
        y = y + self.ffn(y)
        self.prev = y
        return y

    def _split(self, t: Tensor) -> Tensor:
        b, n, c = t.shape
        return t.view(b, n, self.heads, c // self.heads).transpose(1, 2)

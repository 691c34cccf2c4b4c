"""Position-aware pooling (paper Sec. 3.2 "Position-aware pooling"; method.md "Position-aware pooling").

For every 2x2 window (stride 2) a cheap MLP of 1x1 convolutions scores each of the 4 members from its
features, its absolute position (x, y in (-1, 1) over the whole feature map) and its relative position in the
window (one-hot of 4); a softmax over the 4 scores weights the members' sum. ``pixel_unshuffle`` forms the
windows. Odd sizes are replicate-padded to even first, so the output is ``ceil(H/2) x ceil(W/2)``.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn


def position_features(h: int, w: int, like: Tensor) -> Tensor:
    """``[1, 6, h, w]``: absolute x, y at pixel centres in (-1, 1), then the one-hot of the window slot."""
    ys = (torch.arange(h, device=like.device, dtype=like.dtype) * 2 + 1) / h - 1
    xs = (torch.arange(w, device=like.device, dtype=like.dtype) * 2 + 1) / w - 1
    gy, gx = torch.meshgrid(ys, xs, indexing="ij")
    rows, cols = torch.arange(h, device=like.device), torch.arange(w, device=like.device)
    slot = (rows[:, None] % 2) * 2 + cols[None] % 2
    onehot = F.one_hot(slot, 4).permute(2, 0, 1).to(like.dtype)
    return torch.cat([gx[None], gy[None], onehot], 0)[None]


class PositionAwarePool(nn.Module):
    """2x2 stride-2 pooling with learned, position-aware member weights; ``hidden = 0`` is one 1x1 layer."""

    def __init__(self, channels: int, hidden: int = 0) -> None:
        super().__init__()
        cin = channels + 6
        if hidden > 0:
            self.score = nn.Sequential(nn.Conv2d(cin, hidden, 1), nn.ReLU(inplace=True),
                                       nn.Conv2d(hidden, 1, 1))
        else:
            self.score = nn.Conv2d(cin, 1, 1)

    def forward(self, x: Tensor) -> Tensor:
        h, w = x.shape[-2:]
        if h % 2 or w % 2:
            x = F.pad(x, (0, w % 2, 0, h % 2), mode="replicate")
        b, c, h, w = x.shape
        pos = position_features(h, w, x).expand(b, -1, -1, -1)
        scores = F.pixel_unshuffle(self.score(torch.cat([x, pos], 1)), 2)          # [B, 4, h/2, w/2]
        weights = torch.softmax(scores.float(), dim=1).to(x.dtype)
        members = F.pixel_unshuffle(x, 2).view(b, c, 4, h // 2, w // 2)
        return (members * weights[:, None]).sum(2)

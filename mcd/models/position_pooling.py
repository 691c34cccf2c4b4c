"""Position-aware pooling (paper Sec. 4.2 "Position-aware pooling"; docs/method.md "Position-aware pooling").

For every 2x2 window (stride 2) a cheap MLP of 1x1 convolutions scores each of the 4 members from its
features, its absolute position (x, y in (-1, 1) over the whole feature map) and its relative position in the
window (one-hot of 4); a softmax over the 4 scores weights the members' sum. Odd sizes are replicate-padded
to even first, so the output is ``ceil(H/2) x ceil(W/2)``.

No temporary larger than a quarter of the input (docs/inference.md, "Position-aware pooling"): the scoring
MLP's first 1x1 layer is split into its feature part (run on the features) and its position part (run on the
6 position channels and broadcast over the batch), so features and positions are never concatenated; the
members are the four stride-2 views of the input, summed by in-place multiply-adds.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from mcd.core.stages import stage


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

    def scores(self, x: Tensor) -> Tensor:
        """``[B, 1, H, W]`` member scores: the MLP on ``cat([x, position_features])`` without the concat."""
        first = self.score[0] if isinstance(self.score, nn.Sequential) else self.score
        c = x.shape[1]
        pos = position_features(*x.shape[-2:], x)
        y = F.conv2d(x, first.weight[:, :c], first.bias) + F.conv2d(pos, first.weight[:, c:].to(pos.dtype))
        return self.score[1:](y) if isinstance(self.score, nn.Sequential) else y

    @stage("PP")
    def forward(self, x: Tensor) -> Tensor:
        h, w = x.shape[-2:]
        if h % 2 or w % 2:
            x = F.pad(x, (0, w % 2, 0, h % 2), mode="replicate")
        weights = torch.softmax(F.pixel_unshuffle(self.scores(x), 2).float(), dim=1).to(x.dtype)  # [B,4,h,w]
        out = x[..., 0::2, 0::2] * weights[:, 0:1]
        for slot in range(1, 4):                                  # slot = 2 * row offset + column offset
            dy, dx = divmod(slot, 2)
            out.addcmul_(x[..., dy::2, dx::2], weights[:, slot : slot + 1])
        return out

"""The basic building block of both networks: a 3x3 convolution followed by ReLU (paper Sec. 4)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import torch
from torch import Tensor, nn

#: ``block(in_channels, out_channels) -> module`` builds one conv block of a U-Net.
BlockFactory = Callable[[int, int], nn.Module]


class ConvReLU(nn.Module):
    """3x3 convolution (zero padding 1) + ReLU."""

    def __init__(self, cin: int, cout: int) -> None:
        super().__init__()
        self.conv = nn.Conv2d(cin, cout, 3, padding=1)
        self.act = nn.ReLU(inplace=True)

    def forward(self, x: Tensor) -> Tensor:
        return self.act(self.conv(x))


def on_parts(block: nn.Module, parts: Sequence[Tensor], constant: Tensor | None = None) -> Tensor:
    """``block`` on the channel concatenation of ``parts`` and of ``constant`` ``[B, D]`` broadcast over the
    image; a block with a ``forward_parts`` method (Fast GhostConv) is handed them as they are, so it can skip
    the concatenation and the broadcast (docs/inference.md)."""
    forward_parts = getattr(block, "forward_parts", None)
    if callable(forward_parts):
        return forward_parts(parts, constant)
    like = parts[0]
    whole = list(parts)
    if constant is not None:
        whole.append(constant[:, :, None, None].expand(like.shape[0], -1, *like.shape[-2:]).to(like.dtype))
    return block(torch.cat(whole, 1))

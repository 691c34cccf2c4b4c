"""The basic building block of both networks: a 3x3 convolution followed by ReLU (paper Sec. 4)."""

from __future__ import annotations

from collections.abc import Callable

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

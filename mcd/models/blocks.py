"""The basic building block of both networks: a 3x3 convolution followed by ReLU (paper Sec. 4); in CPU
inference mode with the ReLU and a decoder block's concatenation fused into the convolution
(:mod:`mcd.models.cpu_fast.fused_conv`, docs/inference.md)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

from torch import Tensor, nn

from mcd.models.cpu_fast import fused_conv
from mcd.models.cpu_fast.replicate import padded_conv
from mcd.models.inputs import cat_channels, with_constant

#: ``block(in_channels, out_channels) -> module`` builds one conv block of a U-Net.
BlockFactory = Callable[[int, int], nn.Module]


#: ``padding_mode`` of a block's convolutions: ``zeros`` (``F_d`` and the baselines) or ``replicate`` (the
#: sampling network ``F_s``, whose map must not see the frame's border as an edge: docs/method.md "Adaptive
#: sampling", step 6).
PADDING_MODES = ("zeros", "replicate")


def check_padding(padding: str) -> str:
    """``padding`` if it is one of :data:`PADDING_MODES`, else a ``ValueError`` naming it."""
    if padding not in PADDING_MODES:
        raise ValueError(f"padding mode {padding!r}: expected one of {PADDING_MODES}")
    return padding


class ConvReLU(nn.Module):
    """3x3 convolution (padding 1, ``padding``: zeros or replicate) + ReLU."""

    def __init__(self, cin: int, cout: int, padding: str = "zeros") -> None:
        super().__init__()
        self.conv = nn.Conv2d(cin, cout, 3, padding=1, padding_mode=check_padding(padding))
        self.act = nn.ReLU(inplace=True)

    def forward(self, x: Tensor) -> Tensor:
        if self.conv.padding_mode == "zeros" and fused_conv.applies(self.conv.weight, [x]):
            return fused_conv.conv2d(x, self.conv.weight, self.conv.bias, self.conv.padding, relu=True)
        return self.act(padded_conv(self.conv, x))

    def forward_parts(self, parts: Sequence[Tensor], constant: Tensor | None = None) -> Tensor:
        """The block on the channel concatenation of ``parts`` and of ``constant`` ``[B, D]`` broadcast over
        the image; in CPU inference mode without building the concatenation
        (:func:`mcd.models.cpu_fast.fused_conv.conv_on_parts`)."""
        whole = with_constant(parts, constant)
        if self.conv.padding_mode == "zeros" and fused_conv.applies(self.conv.weight, whole):
            return fused_conv.conv_on_parts(self.conv, whole, relu=True)
        return self.forward(cat_channels(whole) if len(whole) > 1 else whole[0])


def on_parts(block: nn.Module, parts: Sequence[Tensor], constant: Tensor | None = None) -> Tensor:
    """``block`` on the channel concatenation of ``parts`` and of ``constant`` ``[B, D]`` broadcast over the
    image; a block with a ``forward_parts`` method (Fast GhostConv) is handed them as they are, so it can skip
    the concatenation and the broadcast (docs/inference.md)."""
    forward_parts = getattr(block, "forward_parts", None)
    if callable(forward_parts):
        return forward_parts(parts, constant)
    return block(cat_channels(with_constant(parts, constant)))

"""The denoising network ``F_d`` (paper Sec. 4; docs/method.md "Networks", "Position-aware pooling", "SA").

A deeper, wider U-Net than ``F_s`` that directly predicts the denoised image in the compressed colour range.
PP swaps its encoder's max pooling for position-aware pooling; SA puts semantic alignment at its deepest level
in place of that level's blocks after the first. With the paper profile (5 levels, 3 blocks, deepest width 64)
that swap removes two 64->64 3x3 convs (73.9 k params) for an attention + FFN block (33.2 k), the ~0.039 M
params that every SA row of the paper's component table loses.
"""

from __future__ import annotations

from functools import partial

from torch import Tensor, nn

from mcd.models.position_pooling import PositionAwarePool
from mcd.models.semantic_alignment import SemanticAlignment
from mcd.models.unet import UNet, max_pool


class Denoiser(nn.Module):
    """``F_d``: ``cin`` channels -> 3 channels (compressed colour)."""

    def __init__(self, cin: int, widths: list[int], convs: int, position_pooling: bool = False,
                 semantic_alignment: bool = False, pp_hidden: int = 0, heads: int = 4,
                 ffn_mult: int = 2) -> None:
        super().__init__()
        pool = partial(PositionAwarePool, hidden=pp_hidden) if position_pooling else max_pool
        self.align = SemanticAlignment(widths[-1], heads, ffn_mult) if semantic_alignment else None
        self.unet = UNet(cin, 3, widths, convs, pool=pool, deepest=self.align, level_labels=True)

    def reset(self) -> None:
        """Drop the semantic-alignment state."""
        if self.align is not None:
            self.align.reset()

    def forward(self, x: Tensor) -> Tensor:
        return self.unet(x)["out"]

"""A configurable U-Net of conv blocks with skip connections (paper Sec. 4: both ``F_s`` and ``F_d``).

Level ``j`` works at ``1 / 2^j`` resolution with ``widths[j]`` channels and ``convs`` blocks; the encoder
pools between levels (max pooling, or position-aware pooling), the decoder upsamples bilinearly, concatenates
the skip and runs ``convs`` blocks (a block that takes its input in parts is handed the upsampled features and
the skip instead, :func:`mcd.models.blocks.on_parts`); a 1x1 convolution makes the output. The deepest level
may swap its blocks after the first for another module (semantic alignment). Inputs of any size are
replicate-padded to a multiple of the stride ``2^(levels-1)`` and the outputs cropped back, so odd sizes and
inputs smaller than the stride work.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext

from torch import Tensor, nn

from mcd.core.stages import stage
from mcd.models.blocks import BlockFactory, ConvReLU, on_parts
from mcd.models.cpu_fast.upsample import upsample_bilinear
from mcd.models.inputs import crop, pad_to_multiple

PoolFactory = Callable[[int], nn.Module]


def max_pool(_channels: int) -> nn.Module:
    """2x2 max pooling (ceil mode, so odd sizes keep their last row/column)."""
    return nn.MaxPool2d(2, ceil_mode=True)


class UNet(nn.Module):
    """U-Net returning ``{"out", "finest", "coarsest"}`` (output, last decoder features, deepest features)."""

    def __init__(self, cin: int, cout: int, widths: list[int], convs: int = 2, block: BlockFactory = ConvReLU,
                 pool: PoolFactory = max_pool, deepest: nn.Module | None = None,
                 level_labels: bool = False) -> None:
        super().__init__()
        #: each level's blocks (and the pool after an encoder level) under a stage label ``L<j>``
        #: (:func:`mcd.core.stages.stage`; the output convolution is level 0's)
        self.level_labels = level_labels
        if len(widths) < 1 or convs < 1:
            raise ValueError(f"a U-Net needs at least one level and one conv per level; "
                             f"got {widths}, {convs}")
        self.widths = list(widths)
        self.stride = 2 ** (len(widths) - 1)
        self.encoder = nn.ModuleList()
        self.pools = nn.ModuleList()
        c = cin
        for j, w in enumerate(widths):
            last = j == len(widths) - 1
            blocks = [block(c, w)]
            if last and deepest is not None:
                blocks.append(deepest)
            else:
                blocks += [block(w, w) for _ in range(convs - 1)]
            self.encoder.append(nn.Sequential(*blocks))
            if not last:
                self.pools.append(pool(w))
            c = w
        self.decoder = nn.ModuleList()
        for j in range(len(widths) - 2, -1, -1):
            w = widths[j]
            self.decoder.append(nn.Sequential(block(c + w, w), *[block(w, w) for _ in range(convs - 1)]))
            c = w
        self.head = nn.Conv2d(c, cout, 1)

    def encode(self, x: Tensor) -> tuple[list[Tensor], Tensor]:
        """The encoder on ``x`` replicate-padded to a multiple of the stride: the skips (each level's
        features before its pooling, finest first) and the deepest level's features."""
        x = pad_to_multiple(x, self.stride)
        skips = []
        for j, level in enumerate(self.encoder):
            with self._label(j):
                x = level(x)
                if j < len(self.pools):
                    skips.append(x)
                    x = self.pools[j](x)
        return skips, x

    def forward(self, x: Tensor) -> dict[str, Tensor]:
        size = x.shape[-2:]
        skips, x = self.encode(x)
        coarsest = x
        for j, (level, skip) in enumerate(zip(self.decoder, reversed(skips), strict=True)):
            with self._label(len(self.decoder) - 1 - j):
                x = upsample_bilinear(x, skip.shape[-2:])
                x = level[1:](on_parts(level[0], [x, skip]))
        with self._label(0):
            out = self.head(x)
        return {"out": crop(out, size), "finest": crop(x, size), "coarsest": coarsest}

    def _label(self, level: int) -> AbstractContextManager:
        return stage(f"L{level}") if self.level_labels else nullcontext()

"""Fast GhostConv (paper Sec. 4.2 "Fast GhostConv"; docs/method.md "Fast GhostConv").

A large-kernel group convolution gathers a wide neighbourhood cheaply; a point-wise convolution mixes its
channels into half the output; a depth-wise 3x3 convolution on that half makes the other ("ghost") half;
concatenation and ReLU. It replaces every 3x3 conv + ReLU block of the sampling network ``F_s``.

The group convolution's output width is not given by the paper; it is ``mid_ratio * cout`` (default 0.5),
which makes the block cheaper than the 3x3 block it replaces, as the paper's component table requires (rows
E, G, H, L lose params and MACs against D, C, J, B). Groups fall back to ``gcd(groups, cin, mid)`` when
``groups`` does not divide both widths (e.g. an input layer of 12 channels with groups 8).

On the CPU the block runs fast paths of the same function (:mod:`mcd.models.cpu_fast.ghost_conv`; their
equivalence tests are in ``tests/models/test_inference_paths.py``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import torch
from torch import Tensor, nn

from mcd.core.stages import stage
from mcd.models import fast_paths
from mcd.models.blocks import check_padding
from mcd.models.cpu_fast import fused_conv
from mcd.models.cpu_fast.ghost_conv import (
    fast_path_applies,
    group_then_point,
    grouped_conv,
    merged_applies,
    merged_primary,
    primary_and_ghost,
    replicate_block,
    replicate_path_applies,
)
from mcd.models.inputs import cat_channels, with_constant


class FastGhostConv(nn.Module):
    """``cin -> cout`` Fast GhostConv block (``cout`` must be even: half primary, half ghost)."""

    def __init__(self, cin: int, cout: int, kernel: int = 7, groups: int = 4, mid_ratio: float = 0.5,
                 padding: str = "zeros") -> None:
        super().__init__()
        if cout % 2:
            raise ValueError(f"FastGhostConv needs an even output width (half primary, half ghost); "
                             f"got {cout}")
        if kernel % 2 == 0:
            raise ValueError(f"FastGhostConv needs an odd group-conv kernel size; got {kernel}")
        mid = max(1, round(cout * mid_ratio))
        g = math.gcd(groups, math.gcd(cin, mid))
        half = cout // 2
        check_padding(padding)
        self.group = nn.Conv2d(cin, mid, kernel, padding=kernel // 2, groups=g, padding_mode=padding)
        self.point = nn.Conv2d(mid, half, 1)
        self.ghost = nn.Conv2d(half, half, 3, padding=1, groups=half, padding_mode=padding)
        self.act = nn.ReLU(inplace=True)

    def forward(self, x: Tensor) -> Tensor:
        return self.forward_parts([x])

    def forward_parts(self, parts: Sequence[Tensor], constant: Tensor | None = None) -> Tensor:
        """The block on the channel concatenation of ``parts`` and of ``constant`` ``[B, D]`` broadcast over
        the image. CPU inference (:func:`fast_path_applies`) runs :func:`group_then_point`, which
        concatenates parts only where a group straddles them and convolves no constant channel
        (docs/inference.md; a U-Net decoder block is handed its upsampled features and skip, the kernel-map
        head the kernel descriptor)."""
        with stage("Ghost conv"):
            return self._forward_parts(parts, constant)

    def _forward_parts(self, parts: Sequence[Tensor], constant: Tensor | None) -> Tensor:
        fast = fast_paths.enabled()
        if fast and replicate_path_applies(self.group, self.ghost, parts):
            return replicate_block(self.group, self.point, self.ghost, parts, constant)
        if fast_path_applies(self.group, parts):
            if self.ghost.padding_mode == "zeros" and fused_conv.applies(self.ghost.weight, parts):
                return primary_and_ghost(self.group, self.point, self.ghost, parts, constant)
            primary = group_then_point(self.group, self.point.weight, self.point.bias, parts, constant)
        else:
            whole = with_constant(parts, constant)
            x = cat_channels(whole) if len(whole) > 1 else whole[0]
            if fast and merged_applies(self.group, x):
                primary = merged_primary(self.group, self.point, x)
            else:
                primary = self.point(grouped_conv(self.group, x))
        return self.act(torch.cat([primary, grouped_conv(self.ghost, primary)], 1))

"""FastDVDnet (Tassano et al. 2020; official code m-tassano/fastdvdnet), docs/baselines.md "FastDVDnet".

A 5-frame window to one output, no flow and no warping. Stage 1: one shared denoising block on the frame
triplets (t-2..t), (t-1..t+1), (t..t+2); stage 2: a second block on those three outputs. A block is the
official ``DenBlock``: grouped 3x3 conv (one group per frame) -> 3x3 conv; two stride-2 downsamplings each
followed by two 3x3 convs; upsampling by a conv to 4x channels + PixelShuffle; additive skips;
conv-BN-ReLU throughout; output = the centre input frame minus the predicted residual.
Inputs per frame: no noise-level map (Monte Carlo noise is not Gaussian); stage 1 gets ``log1p`` colour +
7 G-buffer channels, stage 2 the stage-1 output + the same frame's G-buffers.
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

from mcd.data.buffers import GBUFFERS
from mcd.models.baselines.uniform import uniform_key
from mcd.models.inputs import compress, crop, expand, gbuffers, need, pad_to_multiple
from mcd.models.margin import with_margin
from mcd.models.registry import register

FRAMES = 3  # frames per block


def cbr(cin: int, cout: int, stride: int = 1, groups: int = 1) -> list[nn.Module]:
    """conv(3x3, no bias) - BN - ReLU, as in the official code."""
    return [nn.Conv2d(cin, cout, 3, stride=stride, padding=1, groups=groups, bias=False),
            nn.BatchNorm2d(cout), nn.ReLU(inplace=True)]


class DenBlock(nn.Module):
    """One denoising block on 3 frames of ``per_frame`` channels each (colour first), widths ``(c0, c1, c2)``.
    """

    def __init__(self, per_frame: int, widths: tuple[int, int, int], interm: int) -> None:
        super().__init__()
        c0, c1, c2 = widths
        self.inc = nn.Sequential(*cbr(FRAMES * per_frame, FRAMES * interm, groups=FRAMES),
                                 *cbr(FRAMES * interm, c0))
        self.down0 = nn.Sequential(*cbr(c0, c1, stride=2), *cbr(c1, c1), *cbr(c1, c1))
        self.down1 = nn.Sequential(*cbr(c1, c2, stride=2), *cbr(c2, c2), *cbr(c2, c2))
        self.up2 = nn.Sequential(*cbr(c2, c2), *cbr(c2, c2), nn.Conv2d(c2, c1 * 4, 3, padding=1, bias=False),
                                 nn.PixelShuffle(2))
        self.up1 = nn.Sequential(*cbr(c1, c1), *cbr(c1, c1), nn.Conv2d(c1, c0 * 4, 3, padding=1, bias=False),
                                 nn.PixelShuffle(2))
        self.outc = nn.Sequential(*cbr(c0, c0), nn.Conv2d(c0, 3, 3, padding=1, bias=False))
        nn.init.zeros_(self.outc[-1].weight)  # start as the identity (residual 0), learns faster

    def forward(self, frames: Tensor, centre: Tensor) -> Tensor:
        """``frames`` ``[B, 3 * per_frame, H, W]`` (frame-major), ``centre`` ``[B, 3, H, W]``; H, W multiples
        of 4."""
        x0 = self.inc(frames)
        x1 = self.down0(x0)
        x2 = self.up2(self.down1(x1))
        x1 = self.up1(x1 + x2)
        return centre - self.outc(x0 + x1)


class FastDVDnet(nn.Module):
    """Two-stage FastDVDnet on uniform renders at the budget, ``window = (2, 2)``."""

    window = (2, 2)
    temporal_state = False  # each output depends only on its window
    #: ``method.denoiser_margin`` (mcd.models.margin): every frame of the window is read reflected outside
    #: training
    denoiser_margin = 0

    def __init__(self, budget: int, widths: tuple[int, int, int], interm: int) -> None:
        super().__init__()
        self.key = uniform_key(budget, "fastdvdnet")
        widths = tuple(int(w) for w in widths)
        if len(widths) != 3:
            raise ValueError(f"capacity.fastdvdnet.widths needs 3 block widths, got {list(widths)}")
        self.stage1 = DenBlock(10, widths, int(interm))
        self.stage2 = DenBlock(10, widths, int(interm))

    def required_buffers(self) -> set[str]:
        return {self.key, *GBUFFERS}

    def reset(self) -> None:
        """Stateless: every output depends only on its 5-frame window."""

    def forward(self, x: dict[str, Tensor | None]) -> dict[str, Tensor]:
        noisy = need(x, self.key, "fastdvdnet")
        if noisy.ndim != 5 or noisy.shape[1] != 5:
            raise ValueError(f"fastdvdnet needs 5-frame windows [B, 5, C, H, W] (window=(2, 2)), got "
                             f"{tuple(noisy.shape)} for {self.key!r}")
        b, t = noisy.shape[:2]
        frames = {k: need(x, k, "fastdvdnet").flatten(0, 1) for k in self.required_buffers()}
        g = gbuffers(frames, "fastdvdnet").unflatten(0, (b, t))
        c = compress(frames[self.key]).unflatten(0, (b, t))
        return {"output": expand(with_margin(self, self.denoise, c, g))}

    def denoise(self, c: Tensor, g: Tensor) -> Tensor:
        """The two stages on a window's colour ``c`` ``[B, 5, 3, H, W]`` (compressed) and G-buffers ``g``
        ``[B, 5, 7, H, W]`` of any size (padded to a multiple of 4, cropped back) -> ``[B, 3, H, W]``."""
        b, t, _, h, w = c.shape
        c, g = (pad_to_multiple(v.flatten(0, 1), 4).unflatten(0, (b, t)) for v in (c, g))
        per_frame = torch.cat([c, g], 2)  # [B, 5, 10, H', W']
        stage1 = [self.stage1(per_frame[:, i:i + 3].flatten(1, 2), c[:, i + 1]) for i in range(3)]
        second = torch.cat([torch.cat([s, g[:, i + 1]], 1) for i, s in enumerate(stage1)], 1)
        return crop(self.stage2(second, stage1[1]), (h, w))


#: Its catalogue entries (mcd.config.methods.Method's fields; read from this file without importing it,
#: docs/architecture.md "Methods").
ENTRIES = (
    {"experiment": "fastdvdnet", "display": "FastDVDnet", "table1": True, "bench": True, "train_bench": True,
     "paper": {"psnr": 32.07, "ssim": 86.02, "gmacs": 1083.5, "params_m": 1.867}},
)


@register("fastdvdnet")
def build_fastdvdnet(*, budget: float, widths: list[int], interm: int) -> FastDVDnet:
    """FastDVDnet at ``budget`` with its widths (``capacity.fastdvdnet``): ``widths``, the three block widths
    at 1, 1/2, 1/4; ``interm``, maps per frame after the grouped input conv (docs/baselines.md)."""
    return FastDVDnet(budget, tuple(widths), int(interm))

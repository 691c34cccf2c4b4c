"""RAE, the recurrent denoising autoencoder of Chaitanya et al. 2017 (docs/baselines.md, "RAE").

A U-Net of 3x3 convolutions and LeakyReLU(0.1): five encoder levels (full resolution to 1/16, 2x2 max-pool
between them) and a bottleneck at 1/32, each a recurrent block (conv -> concat with this block's own output
at the previous frame -> conv -> conv; the output is the new hidden state, zero at a clip's start); a
decoder of 2x nearest upsampling, concatenated skip and two convs, whose last level has its own widths.
Colour is demodulated by albedo before the network and modulated back after it (:func:`demodulation`). The
same U-Net without recurrence is DASR's sampler and denoiser (:mod:`mcd.models.baselines.dasr`)."""

from __future__ import annotations

from collections.abc import Sequence

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from mcd.data.buffers import GBUFFERS
from mcd.models.baselines.uniform import uniform_key
from mcd.models.inputs import compress, crop, expand, gbuffers, need, pad_to_multiple
from mcd.models.margin import with_margin
from mcd.models.registry import register

#: Albedo offset of the demodulation ``c / (albedo + eps)`` (black albedo stays finite).
DEMOD_EPS = 1e-2
#: A pixel whose largest albedo channel is at least this is demodulated by ``albedo + DEMOD_EPS``; below it
#: the divisor blends linearly to 1 at albedo 0 (:func:`demodulation`).
DEMOD_FULL = 0.1


def demodulation(albedo: Tensor) -> Tensor:
    """The divisor of RAE's demodulation, ``[B, 3, H, W]``: ``albedo + DEMOD_EPS`` where the largest albedo
    channel is at least :data:`DEMOD_FULL`, blending linearly (in that channel) to 1 at albedo 0.

    Mitsuba's albedo is 0 on an area light, so ``c / (albedo + eps)`` made every visible light 100x brighter
    in the network's input (a light of radiance 65 entered as 6500, ``log1p`` 8.8 against 0.4-1.8 for lit
    surfaces), and the trained RAE put 800-1275 on cornell-box-picture's light (docs/baselines.md, "Choices
    the papers leave open"). Exactly invertible whatever the blend: the output is multiplied by the same
    divisor."""
    a = albedo.clamp_min(0)
    t = (a.amax(dim=1, keepdim=True) / DEMOD_FULL).clamp(max=1.0)
    return 1.0 + t * (a + DEMOD_EPS - 1.0)


def conv(cin: int, cout: int) -> nn.Conv2d:
    return nn.Conv2d(cin, cout, 3, padding=1)


class RecurrentBlock(nn.Module):
    """conv -> concat with the previous frame's output of this block -> conv -> conv (LeakyReLU 0.1 each)."""

    def __init__(self, cin: int, width: int) -> None:
        super().__init__()
        self.c1, self.c2, self.c3 = conv(cin, width), conv(2 * width, width), conv(width, width)
        self.width = width
        self.state: Tensor | None = None

    def reset(self) -> None:
        self.state = None

    def forward(self, x: Tensor) -> Tensor:
        y = F.leaky_relu(self.c1(x), 0.1)
        if self.state is None:
            h = torch.zeros_like(y)
        elif self.state.shape != y.shape:
            raise RuntimeError(f"RAE hidden state has shape {tuple(self.state.shape)} but this frame gives "
                               f"{tuple(y.shape)}: call reset() at the start of every sequence or clip")
        else:
            h = self.state
        y = F.leaky_relu(self.c2(torch.cat([y, h], 1)), 0.1)
        y = F.leaky_relu(self.c3(y), 0.1)
        self.state = y
        return y


class PlainBlock(nn.Module):
    """Two 3x3 convs with LeakyReLU 0.1 (the non-recurrent level of DASR's U-Net)."""

    def __init__(self, cin: int, width: int) -> None:
        super().__init__()
        self.c1, self.c2 = conv(cin, width), conv(width, width)

    def reset(self) -> None:
        """Stateless."""

    def forward(self, x: Tensor) -> Tensor:
        return F.leaky_relu(self.c2(F.leaky_relu(self.c1(x), 0.1)), 0.1)


class RAEUNet(nn.Module):
    """The RAE U-Net: ``encoder`` widths from full resolution to 1/16, ``bottleneck`` at 1/32, ``last`` the
    two widths of the full-resolution decoder level; decoder level ``i`` has the width of encoder level
    ``i - 1``. ``recurrent=False`` gives DASR's network (two convs per level, no state)."""

    def __init__(self, cin: int, cout: int, encoder: Sequence[int], bottleneck: int, last: Sequence[int],
                 recurrent: bool) -> None:
        super().__init__()
        if len(last) != 2 or len(encoder) < 1:
            raise ValueError(f"RAE/DASR U-Net needs >= 1 encoder width and 2 'last' widths, got {encoder}, "
                             f"{last}")
        block = RecurrentBlock if recurrent else PlainBlock
        enc = [int(w) for w in encoder]
        self.levels = len(enc)
        self.encoder = nn.ModuleList()
        c = cin
        for w in enc:
            self.encoder.append(block(c, w))
            c = w
        self.bottleneck = block(c, int(bottleneck))
        self.decoder = nn.ModuleList()
        prev = int(bottleneck)
        for i in range(self.levels - 1, 0, -1):
            w = enc[i - 1]
            self.decoder.append(nn.ModuleList([conv(prev + enc[i], w), conv(w, w)]))
            prev = enc[i - 1]
        self.last = nn.ModuleList([conv(prev + enc[0], int(last[0])), conv(int(last[0]), int(last[1]))])
        self.out = conv(int(last[1]), cout)

    def reset(self) -> None:
        for b in [*self.encoder, self.bottleneck]:
            b.reset()

    @property
    def stride(self) -> int:
        return 2**self.levels

    def forward(self, x: Tensor) -> Tensor:
        """``x`` ``[B, cin, H, W]`` with H, W multiples of :attr:`stride`."""
        skips = []
        for i, b in enumerate(self.encoder):
            x = b(x if i == 0 else F.max_pool2d(x, 2))
            skips.append(x)
        x = self.bottleneck(F.max_pool2d(x, 2))
        for convs, skip in zip([*self.decoder, self.last], reversed(skips), strict=True):
            x = torch.cat([F.interpolate(x, scale_factor=2.0, mode="nearest"), skip], 1)
            x = F.leaky_relu(convs[1](F.leaky_relu(convs[0](x), 0.1)), 0.1)
        return self.out(x)


class RAE(nn.Module):
    """RAE on the uniform render at the budget: demodulated ``log1p`` colour + G-buffers (10 channels)."""

    window = (0, 0)
    temporal_state = True  # recurrent blocks
    #: ``method.denoiser_margin`` (mcd.models.margin): the network reads the frame reflected outside training;
    #: its hidden states are then at the reflected size on every frame of a sequence
    denoiser_margin = 0

    def __init__(self, budget: int, encoder: Sequence[int], bottleneck: int, last: Sequence[int]) -> None:
        super().__init__()
        self.key = uniform_key(budget, "rae")
        self.net = RAEUNet(10, 3, encoder, bottleneck, last, recurrent=True)

    def required_buffers(self) -> set[str]:
        return {self.key, *GBUFFERS}

    def reset(self) -> None:
        self.net.reset()

    def forward(self, x: dict[str, Tensor | None]) -> dict[str, Tensor]:
        noisy = need(x, self.key, "rae")
        divisor = demodulation(need(x, "albedo", "rae"))
        inp = torch.cat([compress(noisy / divisor), gbuffers(x, "rae")], 1)
        return {"output": expand(with_margin(self, self.denoise, inp)) * divisor}

    def denoise(self, inp: Tensor) -> Tensor:
        """The recurrent U-Net on ``inp`` ``[B, 10, H, W]`` of any size (padded to its stride, cropped
        back)."""
        return crop(self.net(pad_to_multiple(inp, self.net.stride)), inp.shape[-2:])


#: Its catalogue entries (mcd.config.methods.Method's fields; read from this file without importing it,
#: docs/architecture.md "Methods").
ENTRIES = (
    {"experiment": "rae", "display": "RAE", "table1": True, "bench": True, "train_bench": True,
     "paper": {"psnr": 31.96, "ssim": 86.07, "gmacs": 432.61, "params_m": 1.864}},
)


@register("rae")
def build_rae(*, budget: float, encoder: list[int], bottleneck: int, last: list[int]) -> RAE:
    """RAE at ``budget`` with its widths (``capacity.rae``): ``encoder`` (recurrent levels, full resolution ..
    1/16), ``bottleneck`` (recurrent, 1/32), ``last`` (the full-resolution decoder's two convs)."""
    return RAE(budget, encoder, int(bottleneck), last)

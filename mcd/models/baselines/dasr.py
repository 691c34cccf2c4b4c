"""DASR, deep adaptive sampling and reconstruction (Kuznetsov et al. 2018; docs/baselines.md "DASR").

Sampler and denoiser are the same U-Net, RAE's without recurrence
(:class:`~mcd.models.baselines.rae.RAEUNet`, ``recurrent=False``). The sampler sees the 1 spp render
``c1_in`` (``log1p``), the G-buffers (albedo, normal, log depth) and grey ``c_1`` and albedo, and predicts
logits; the map ``m = round(N (s - 1) softmax)``, capped and re-normalised to the exact budget, drives the
simulated render from the 2^k stack, blended with ``c_1``; the gradient through the render is DASR's own
``dI/dn ~ (ref - I) / n``. All three steps are the project's shared code
(:func:`mcd.sampling.adaptive_render`). The denoiser sees the adaptive image (``log1p``) + G-buffers.

Training: the original trains in stages (denoiser on random smooth maps, then sampler, then both); here both
networks are trained jointly from the start with DASR's loss (``loss=dasr``), as docs/baselines.md allows.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import Tensor, nn

from mcd.data.buffers import GBUFFERS
from mcd.models.baselines.rae import RAEUNet
from mcd.models.inputs import compress, crop, expand, gbuffers, grey, need, pad_to_multiple
from mcd.models.margin import with_margin
from mcd.models.registry import register
from mcd.sampling import adaptive_render, stack_buffers, stack_names


class DASR(nn.Module):
    """Sampler + denoiser (two non-recurrent RAE U-Nets), adaptive sampling at average budget ``budget``."""

    window = (0, 0)
    temporal_state = False  # single-frame
    #: ``method.denoiser_margin`` (mcd.models.margin): the denoiser (not the sampler) reads the adaptive image
    #: reflected outside training
    denoiser_margin = 0

    def __init__(self, budget: float, encoder: Sequence[int], bottleneck: int, last: Sequence[int],
                 levels: int = 5) -> None:
        super().__init__()
        if budget < 1:
            raise ValueError(f"dasr: budget={budget} is below the 1 spp that c1_in already spends")
        self.budget, self.levels = float(budget), int(levels)
        self.sampler = RAEUNet(12, 1, encoder, bottleneck, last, recurrent=False)
        self.denoiser = RAEUNet(10, 3, encoder, bottleneck, last, recurrent=False)

    def required_buffers(self) -> set[str]:
        return {"c1_in", *stack_names(self.levels), *GBUFFERS}

    def reset(self) -> None:
        """Stateless (single frame)."""

    def forward(self, x: dict[str, Tensor | None]) -> dict[str, Tensor]:
        c1 = need(x, "c1_in", "dasr")
        h, w = c1.shape[-2:]
        g = gbuffers(x, "dasr")
        s_in = torch.cat([compress(c1), g, grey(compress(c1)), grey(need(x, "albedo", "dasr"))], 1)
        logits = crop(self.sampler(pad_to_multiple(s_in, self.sampler.stride)), (h, w))
        i, m = adaptive_render(logits, c1, stack_buffers(x, self.levels), x.get("ref"), self.budget)
        d_in = torch.cat([compress(i.to(c1.dtype)), g], 1)
        return {"output": expand(with_margin(self, self.denoise, d_in)), "sampling_map": m, "adaptive": i}

    def denoise(self, d_in: Tensor) -> Tensor:
        """The denoiser on ``d_in`` ``[B, 10, H, W]`` of any size (padded to its stride, cropped back)."""
        return crop(self.denoiser(pad_to_multiple(d_in, self.denoiser.stride)), d_in.shape[-2:])


#: Its catalogue entries (mcd.config.methods.Method's fields; read from this file without importing it,
#: docs/architecture.md "Methods").
ENTRIES = (
    {"experiment": "dasr", "display": "DASR", "table1": True, "bench": True, "train_bench": True,
     "paper": {"psnr": 31.97, "ssim": 86.08, "gmacs": 558.00, "params_m": 1.577}},
    {"experiment": "dasr_paper_loss", "display": "DASR (paper's loss)", "variant_of": "dasr"},
)


@register("dasr")
def build_dasr(*, budget: float, encoder: list[int], bottleneck: int, last: list[int],
               sampling: dict) -> DASR:
    """DASR at ``budget`` with its widths (``capacity.dasr``): ``encoder`` (full resolution .. 1/16),
    ``bottleneck``, ``last`` (the full-resolution decoder's two convs); ``sampling.levels`` (5) of
    conf/method/dasr.yaml (docs/baselines.md)."""
    return DASR(float(budget), encoder, int(bottleneck), last, int(sampling["levels"]))

"""NTASAD, neural temporal adaptive sampling and denoising (Hasselgren et al. 2020; docs/baselines.md
"NTASAD").

Sampler and denoiser are two U-Nets of one design (:class:`NTASADUNet`): two full-resolution convs of width
``enc``, then max-pool + one conv of width ``enc`` at each of 1/2..1/32; a decoder of nearest upsampling +
concatenated skip + two convs of width ``dec`` at 1/16..1/2; the full-resolution decoder level concatenates
the raw input instead of a skip and has two convs of width ``full``; 3x3 heads read the decoder levels.

Temporal feedback: only the final output is fed back, warped to the current frame by the motion vectors
(:func:`~mcd.models.warp.warp`), to both networks; the first frame's "previous output" is the
uniform render at the budget. Sampler inputs: G-buffers, motion vectors, grey albedo and the grey warped
previous output (``log1p``); its logits drive the project's adaptive render
(:func:`mcd.sampling.adaptive_render`: map normalisation to the exact budget, simulated render from the 2^k
stack blended with ``c1_in``, DASR gradient). Denoiser inputs: the adaptive image, G-buffers, the warped
previous output (colour in ``log1p``).

Hierarchical kernel prediction: per-pixel 5x5 kernels (softmax over taps) filter the adaptive image at 1/4
and 1/2 (average-pooled) and at full resolution, where a spatial 5x5 on the image and a temporal 5x5 on the
warped previous output share one softmax over their 50 taps. Levels combine coarse to fine as ``o = i_f - a
Up(Down(i_f)) + a Up(i_c)`` with a per-pixel blend weight ``a = sigmoid(.)`` predicted at 1/2 and full
resolution (the coarsest level has nothing coarser to blend, so its head has only the 25 taps).

Two diagnostic switches, not NTASAD's design (docs/baselines.md "NTASAD's diagnostics"): ``method.warp=false``
gives it zero motion vectors (the previous output is fed back unwarped, the sampler reads zero motion, and
the motion buffer is not loaded); ``method.previous_output=false`` feeds zeros in place of the previous output
on every frame (no temporal input, the first frame's included)."""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from mcd.data.buffers import GBUFFERS
from mcd.models.baselines.uniform import uniform_key
from mcd.models.inputs import compress, crop, gbuffers, grey, need, pad_to_multiple
from mcd.models.kernel_pool import apply_pixel_kernels
from mcd.models.margin import with_margin
from mcd.models.registry import register
from mcd.models.warp import warp
from mcd.sampling import adaptive_render, stack_buffers, stack_names

#: Per-pixel kernel size at every level.
K = 5
#: Motion vectors enter the sampler divided by this (pixels per frame -> order 1).
MOTION_SCALE = 8.0
#: Resolutions (as divisors) of the U-Net: full, 1/2 ... 1/32.
DEPTH = 5


class NTASADUNet(nn.Module):
    """NTASAD's U-Net; ``heads`` maps a decoder resolution divisor (1, 2, 4, ...) to its output channels."""

    def __init__(self, cin: int, enc: int, dec: int, full: int, heads: dict[int, int]) -> None:
        super().__init__()
        self.enc0 = nn.Sequential(nn.Conv2d(cin, enc, 3, padding=1), nn.ReLU(inplace=True),
                                  nn.Conv2d(enc, enc, 3, padding=1), nn.ReLU(inplace=True))
        self.down = nn.ModuleList(nn.Conv2d(enc, enc, 3, padding=1) for _ in range(DEPTH))
        self.up = nn.ModuleList()
        prev = enc
        for _ in range(DEPTH - 1):
            self.up.append(nn.ModuleList([nn.Conv2d(prev + enc, dec, 3, padding=1),
                                          nn.Conv2d(dec, dec, 3, padding=1)]))
            prev = dec
        self.full = nn.ModuleList([nn.Conv2d(prev + cin, full, 3, padding=1),
                                   nn.Conv2d(full, full, 3, padding=1)])
        bad = [r for r in heads if r not in [2**i for i in range(DEPTH)]]
        if bad:
            raise ValueError(f"NTASAD heads at divisors {bad}: the decoder has levels 1, 2, ..., "
                             f"{2 ** (DEPTH - 1)}")
        self.heads = nn.ModuleDict({str(r): nn.Conv2d(full if r == 1 else dec, c, 3, padding=1)
                                    for r, c in heads.items()})

    @property
    def stride(self) -> int:
        return 2**DEPTH

    def forward(self, x: Tensor) -> dict[int, Tensor]:
        """``x`` ``[B, cin, H, W]`` (H, W multiples of :attr:`stride`) -> ``{divisor: head output}``."""
        skips = [self.enc0(x)]
        for conv in self.down:
            skips.append(F.relu(conv(F.max_pool2d(skips[-1], 2))))
        y = skips[-1]
        out: dict[int, Tensor] = {}
        for level, convs in zip(range(DEPTH - 1, 0, -1), self.up, strict=True):
            y = torch.cat([F.interpolate(y, scale_factor=2.0, mode="nearest"), skips[level]], 1)
            y = F.relu(convs[1](F.relu(convs[0](y))))
            if str(2**level) in self.heads:
                out[2**level] = self.heads[str(2**level)](y)
        y = torch.cat([F.interpolate(y, scale_factor=2.0, mode="nearest"), x], 1)
        y = F.relu(self.full[1](F.relu(self.full[0](y))))
        if "1" in self.heads:
            out[1] = self.heads["1"](y)
        return out


def up2(x: Tensor) -> Tensor:
    return F.interpolate(x, scale_factor=2.0, mode="bilinear", align_corners=False)


def combine(fine: Tensor, coarse: Tensor, a: Tensor) -> Tensor:
    """``o = i_f - a Up(Down(i_f)) + a Up(i_c)``: replace the fine level's low band by the coarse level's."""
    return fine - a * up2(F.avg_pool2d(fine, 2)) + a * up2(coarse)


class NTASAD(nn.Module):
    """Sampler + hierarchical-kernel denoiser with warped output feedback at average budget ``budget``."""

    window = (0, 0)
    temporal_state = True  # the previous output, warped
    #: ``method.denoiser_margin`` (mcd.models.margin): the denoiser and its kernels read the adaptive image,
    #: G-buffers and warped previous output reflected outside training; the sampler, the warp and the fed-back
    #: output stay at the frame's size
    denoiser_margin = 0

    def __init__(self, budget: int, enc: int, dec: int, full: int, levels: int = 5, warp: bool = True,
                 previous_output: bool = True) -> None:
        super().__init__()
        self.budget, self.levels = int(budget), int(levels)
        #: ``method.warp``: the previous output is warped by the motion vectors (false: zero motion)
        self.warp = bool(warp)
        #: ``method.previous_output``: the previous output is fed back (false: zeros on every frame)
        self.previous_output = bool(previous_output)
        self.first_key = uniform_key(self.budget, "ntasad")
        taps = K * K
        self.sampler = NTASADUNet(11, enc, dec, full, {1: 1})
        self.denoiser = NTASADUNet(13, enc, dec, full, {4: taps, 2: taps + 1, 1: 2 * taps + 1})
        self.prev: Tensor | None = None

    def required_buffers(self) -> set[str]:
        return {"c1_in", *stack_names(self.levels), self.first_key, *GBUFFERS,
                *(["motion"] if self.warp else [])}

    def reset(self) -> None:
        self.prev = None

    def previous(self, x: dict[str, Tensor | None]) -> Tensor:
        """The previous output warped to this frame, or the uniform render at the budget on a first frame;
        unwarped with ``warp`` off, zeros with ``previous_output`` off."""
        if not self.previous_output:
            return torch.zeros_like(need(x, "c1_in", "ntasad"))
        if self.prev is None:
            return need(x, self.first_key, "ntasad")
        if not self.warp:
            return self.prev
        motion = need(x, "motion", "ntasad")
        if self.prev.shape[0] != motion.shape[0] or self.prev.shape[-2:] != motion.shape[-2:]:
            raise RuntimeError(f"NTASAD's previous output has shape {tuple(self.prev.shape)} but this frame "
                               f"is {tuple(motion.shape)}: call reset() at the start of every sequence/clip")
        return warp(self.prev, motion)

    def forward(self, x: dict[str, Tensor | None]) -> dict[str, Tensor]:
        c1 = need(x, "c1_in", "ntasad")
        h, w = c1.shape[-2:]
        prev = self.previous(x)
        g = gbuffers(x, "ntasad")
        motion = (need(x, "motion", "ntasad") / MOTION_SCALE if self.warp
                  else c1.new_zeros((c1.shape[0], 2, h, w)))
        s_in = torch.cat([g, motion, grey(need(x, "albedo", "ntasad")), grey(compress(prev))], 1)
        logits = crop(self.sampler(pad_to_multiple(s_in, self.sampler.stride))[1], (h, w))
        i, m = adaptive_render(logits, c1, stack_buffers(x, self.levels), x.get("ref"), float(self.budget))
        i = i.to(c1.dtype)
        o = with_margin(self, self.denoise, i, g, prev).clamp_min(0)
        self.prev = o
        return {"output": o, "sampling_map": m, "adaptive": i}

    def denoise(self, i: Tensor, g: Tensor, prev: Tensor) -> Tensor:
        """The hierarchical kernels (module docstring) predicted from the adaptive image ``i``, the G-buffers
        ``g`` and the warped previous output ``prev`` (``[B, C, H, W]`` of any size: padded to the denoiser's
        stride, cropped back), applied to ``i`` and ``prev``."""
        h, w = i.shape[-2:]
        stride = self.denoiser.stride
        heads = self.denoiser(pad_to_multiple(torch.cat([compress(i), g, compress(prev)], 1), stride))
        img, prev_p = pad_to_multiple(i, stride), pad_to_multiple(prev, stride)
        taps = K * K
        o = apply_pixel_kernels(F.avg_pool2d(img, 4), torch.softmax(heads[4], 1))
        f2 = apply_pixel_kernels(F.avg_pool2d(img, 2), torch.softmax(heads[2][:, :taps], 1))
        o = combine(f2, o, torch.sigmoid(heads[2][:, taps:]))
        k1 = torch.softmax(heads[1][:, : 2 * taps], 1)
        f1 = apply_pixel_kernels(img, k1[:, :taps]) + apply_pixel_kernels(prev_p, k1[:, taps:])
        return crop(combine(f1, o, torch.sigmoid(heads[1][:, 2 * taps:])), (h, w))


#: Its catalogue entries (mcd.config.methods.Method's fields; read from this file without importing it,
#: docs/architecture.md "Methods").
ENTRIES = (
    {"experiment": "ntasad", "display": "NTASAD", "table1": True, "bench": True, "train_bench": True,
     "paper": {"psnr": 32.13, "ssim": 86.46, "gmacs": 826.11, "params_m": 1.578}},
    {"experiment": "ntasad_no_warp", "display": "NTASAD, no warp (diagnostic)", "variant_of": "ntasad",
     "diagnostic": True},
    {"experiment": "ntasad_no_previous", "display": "NTASAD, no previous output (diagnostic)",
     "variant_of": "ntasad", "diagnostic": True},
)


@register("ntasad")
def build_ntasad(*, budget: float, enc: int, dec: int, full: int, sampling: dict,
                 warp: bool = True, previous_output: bool = True) -> NTASAD:
    """NTASAD at ``budget`` with its widths (``capacity.ntasad``): ``enc`` (encoder, every level), ``dec``
    (decoder, 1/16 .. 1/2), ``full`` (full-resolution decoder); ``sampling.levels`` (5), and the diagnostic
    switches ``warp`` and ``previous_output`` (module docstring) of conf/method/ntasad.yaml
    (docs/baselines.md)."""
    return NTASAD(budget, int(enc), int(dec), int(full), int(sampling["levels"]),
                  warp=bool(warp), previous_output=bool(previous_output))

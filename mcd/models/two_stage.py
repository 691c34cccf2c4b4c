"""The two-stage model of the component study, composed from the switches ``UN AS KP PP FG SA``
(docs/method.md).

- UN: the denoiser ``F_d`` (always on). Without AS it denoises the uniform render at the budget, ``c_s``.
- AS: the sampling network ``F_s`` predicts logits, :func:`mcd.sampling.adaptive_render` turns them into the
  sampling map ``m`` and the adaptive image ``i``; ``F_d`` sees ``i`` and ``g`` (and ``m / (s - 1)`` with
  ``method.denoiser_reads_map``, off by default: docs/method.md "F against the paper").
- KP (needs AS): ``F_s`` also predicts the kernel map; the kernel pool's per-pixel kernels give ``i_bar``;
  ``F_d`` sees ``i_bar`` and ``g`` (paper Sec. 4.1: each pixel of ``i_bar`` switches between
  the filtered and the raw adaptive pixel, so ``F_d`` does not read ``i`` itself). ``method.kp.head_output``
  chooses what enters the kernel map's ``tanh`` (mcd.models.kernel_pool, docs/kernel_pool.md).
- PP: position-aware pooling in ``F_d``'s encoder. FG (needs AS): Fast GhostConv blocks in ``F_s``.
  SA: semantic alignment at ``F_d``'s deepest level (state across frames until :meth:`reset`).
Colour is compressed inside (``method.colour``, default ``log1p``); inputs and outputs are linear HDR.
``method.denoiser_output=residual`` adds ``F_d``'s prediction to its colour input (the paper's ``F_d``
predicts the image directly, Sec. 4, ``direct``; docs/method.md "Output"); the output steps after it
(``method.mean_match``, ``method.pass_misses``) are every method's (mcd.models.output_steps), against the
render ``F_d`` denoised: ``i`` (``out["adaptive"]``) with AS, ``c_s`` without.
``method.denoiser_margin`` reflects ``F_d``'s input by that many pixels on every side outside training and
crops its output back (every method's denoiser: mcd.models.margin; docs/method.md "Frame edges").
``method.denoiser_hue=i_bar`` or ``i_bar_grey`` (not the paper's; needs KP) keeps ``F_d``'s luminance and
takes the output's hue from ``i_bar`` (mcd.models.hue, docs/method.md "Output"); ``i_bar_grey`` also makes
``F_d``'s residual correction the same for the three channels.
``method.warp_previous`` (not the paper's; a diagnostic, docs/method.md "Diagnostics") also feeds ``F_d`` its
previous output, warped to this frame by the motion vectors as NTASAD's is (on a sequence's first frame, its
own colour input). The stages run under :func:`mcd.core.stages.stage` labels (:data:`STAGES`, ``F_d``'s
levels ``L0``..., ``PP``, ``SA``, ``Ghost conv``), which ``python -m mcd.bench profile`` reads
(docs/inference.md "Stage profile").
"""

from __future__ import annotations

import torch
from torch import Tensor, nn

from mcd.core.stages import stage
from mcd.data.buffers import GBUFFERS, uniform_buffer
from mcd.models.denoiser import Denoiser
from mcd.models.hue import grey_correction, hue_from
from mcd.models.init import initialise
from mcd.models.inputs import cat_channels, compress, expand, gbuffers, grey, need
from mcd.models.kernel_pool import kp_options_of, pool_picture
from mcd.models.margin import with_margin
from mcd.models.misses import miss_mask
from mcd.models.registry import register
from mcd.models.sampler import SamplingNetwork
from mcd.models.switches import check_switches
from mcd.models.warp import warp
from mcd.sampling import adaptive_render, cap_for_levels, stack_buffers, stack_names

#: ``method.denoiser_output``: ``direct`` (the paper: ``F_d`` predicts the image) or ``residual`` (``F_d``
#: predicts a correction added to its colour input, ``i_bar``, ``i`` or ``c_s``, in the compressed range).
DENOISER_OUTPUTS = ("direct", "residual")
#: ``method.denoiser_hue``: ``free`` (the paper: ``F_d`` gives every channel), ``i_bar`` (the output's hue
#: from the kernel pool's ``i_bar``, its luminance from ``F_d``: mcd.models.hue; needs KP) or ``i_bar_grey``
#: (the same, with ``F_d``'s residual correction one value per pixel for the three channels; needs KP and
#: ``denoiser_output=residual``).
DENOISER_HUES = ("free", "i_bar", "i_bar_grey")
#: Labels of the top-level stages of :meth:`TwoStage.forward` (nested ones: ``kernel-map head`` and ``kernel
#: application`` in ``kernel pool``; ``F_d``'s levels, ``PP`` and ``SA`` in ``F_d``; ``Ghost conv`` in ``F_s``
#: and the kernel-map head).
STAGES = ("input packing", "F_s", "adaptive render", "kernel pool", "F_d", "output steps")


class TwoStage(nn.Module):
    """Rows A-M of the component study; see the module docstring."""

    window = (0, 0)
    #: ``method.denoiser_margin``: pixels of reflection around ``F_d``'s input outside training (set by
    #: :func:`mcd.models.margin.set_margin`)
    denoiser_margin = 0

    def __init__(self, switches: dict[str, bool], budget: float, widths: dict, levels: int = 5,
                 colour: str = "log1p", kp: dict | None = None, denoiser_output: str = "direct",
                 sampler_padding: str = "zeros", reads_map: bool = False,
                 warp_previous: bool = False, init: str = "torch", hue: str = "free") -> None:
        super().__init__()
        if hue not in DENOISER_HUES:
            raise ValueError(f"method.denoiser_hue={hue!r}; use one of {DENOISER_HUES}")
        if hue != "free" and not switches.get("KP"):
            raise ValueError(f"method.denoiser_hue={hue} takes the hue from the kernel pool's i_bar, which "
                             "this row does not have (KP off): set method.denoiser_hue=free, or use a row "
                             "with KP (C-J)")
        if hue == "i_bar_grey" and denoiser_output != "residual":
            raise ValueError("method.denoiser_hue=i_bar_grey makes F_d's residual correction grey, and "
                             f"method.denoiser_output={denoiser_output} has none: set "
                             "method.denoiser_output=residual, or method.denoiser_hue=i_bar")
        #: ``method.denoiser_hue`` other than ``free``: the output's hue from ``i_bar`` (mcd.models.hue)
        self.hue_from_ibar = hue != "free"
        #: ``method.denoiser_hue=i_bar_grey``: ``F_d``'s correction is one value per pixel
        #: (mcd.models.hue.grey_correction)
        self.grey_residual = hue == "i_bar_grey"
        #: ``method.warp_previous``: ``F_d`` also reads its previous output warped by the motion vectors
        self.warp_previous = bool(warp_previous)
        self.prev: Tensor | None = None
        #: ``method.denoiser_reads_map``: ``F_d`` reads the normalised sampling map ``m / (s - 1)`` (with AS)
        self.reads_map = bool(reads_map)
        self.sw = dict(switches)
        self.budget, self.levels, self.colour = float(budget), levels, colour
        if denoiser_output not in DENOISER_OUTPUTS:
            raise ValueError(f"method.denoiser_output={denoiser_output!r}; use one of {DENOISER_OUTPUTS}")
        self.residual = denoiser_output == "residual"
        compress(torch.zeros(1), colour)                                  # fail early on an unknown transform
        den = widths["denoiser"]
        if self.sw["AS"]:
            if not 1 < self.budget <= cap_for_levels(levels) + 1:
                raise ValueError(f"budget={budget}: adaptive sampling needs 1 < s <= "
                                 f"{cap_for_levels(levels) + 1} (c_1 spends one sample; the stack of "
                                 f"{levels + 1} renders caps a pixel at "
                                 f"{cap_for_levels(levels)} more)")
            smp = widths["sampler"]
            self.sampler: SamplingNetwork | None = SamplingNetwork(
                list(smp["widths"]), smp["convs"], kernel_pool=self.sw["KP"], ghost=self.sw["FG"],
                ghost_cfg=dict(widths.get("ghost", {})), kp_cfg=dict(widths.get("kernel_pool", {})),
                kp_options=kp, padding=sampler_padding)
            self.reads_adaptive = not self.sw["KP"]
            options = kp_options_of(kp)
            highlight = options["highlight"]
            #: ``method.kp.highlight`` in the network range: the kernel pool filters below it
            self.kp_ceiling = (None if highlight is None
                               else float(compress(torch.tensor(highlight, device="cpu"), colour)))
            #: ``method.kp.skip_misses``: the kernel pool reads and changes only pixels that saw geometry
            self.kp_skip_misses = options["skip_misses"]
            cin = (3 if self.sw["KP"] else 0) + (3 if self.reads_adaptive else 0) + 7 + int(self.reads_map)
        else:
            self.sampler = None
            uniform = uniform_buffer(self.budget)
            if self.budget != int(self.budget) or uniform not in stack_names(levels):
                raise ValueError(f"budget={budget}: without AS the denoiser reads the uniform render c_s, "
                                 f"which exists for s in {stack_names(levels)} only")
            cin = 3 + 7
        cin += 3 if self.warp_previous else 0
        pp = widths.get("pooling", {})
        att = widths.get("attention", {})
        self.denoiser = Denoiser(cin, list(den["widths"]), den["convs"], position_pooling=self.sw["PP"],
                                 semantic_alignment=self.sw["SA"], pp_hidden=pp.get("hidden", 0),
                                 heads=att.get("heads", 4), ffn_mult=att.get("ffn_mult", 2))
        initialise(self, init)

    @property
    def temporal_state(self) -> bool:
        """Semantic alignment and the warped previous output carry state from frame to frame
        (mcd.lit.module skips the clip frames the loss does not read for rows without either)."""
        return self.sw["SA"] or self.warp_previous

    def required_buffers(self) -> set[str]:
        motion = {"motion"} if self.warp_previous else set()
        if self.sw["AS"]:
            return {"c1_in", *stack_names(self.levels), *GBUFFERS, *motion}
        return {uniform_buffer(self.budget), *GBUFFERS, *motion}

    def reset(self) -> None:
        self.denoiser.reset()
        self.prev = None

    def previous(self, x: dict[str, Tensor | None], colour: Tensor) -> Tensor:
        """``F_d``'s previous output (network range) warped to this frame by the motion vectors, or
        ``colour`` (its colour input) on a sequence's first frame (``method.warp_previous``)."""
        if self.prev is None:
            return colour
        motion = need(x, "motion", "two_stage")
        if self.prev.shape[0] != motion.shape[0] or self.prev.shape[-2:] != motion.shape[-2:]:
            raise RuntimeError(f"F_d's previous output has shape {tuple(self.prev.shape)} but this frame "
                               f"is {tuple(motion.shape)}: call reset() at each sequence/clip start")
        return warp(self.prev, motion.float())

    def sampler_input(self, x: dict[str, Tensor | None]) -> Tensor:
        """``F_s``'s input (docs/method.md "Inputs"): ``c_1``, ``g``, grey ``c_1`` and grey albedo."""
        who = "two_stage"
        c1, albedo = need(x, "c1_in", who), need(x, "albedo", who)
        return cat_channels([compress(c1, self.colour), gbuffers(x, who), compress(grey(c1), self.colour),
                             grey(albedo)])

    def denoise(self, z: Tensor) -> Tensor:
        """``F_d`` on its input ``z`` ``[B, C, H, W]``; outside training on ``z`` reflected by
        ``denoiser_margin`` pixels (at most ``H - 1`` and ``W - 1``) on every side, the output cropped back,
        so no pixel of the frame lies on the network's zero-padded edge
        (:func:`mcd.models.margin.with_margin`, docs/method.md "Frame edges")."""
        return with_margin(self, self.denoiser, z)

    def advance(self, x: dict[str, Tensor | None]) -> None:
        """Carry the state of frame ``x`` to the next frame without computing its output (a training clip's
        frame that takes no gradient and whose output the loss does not read:
        :meth:`mcd.lit.module.DenoiseModule.run_clip`). The state is semantic alignment's, which ``F_d``'s
        encoder makes from ``F_d``'s input; so the frame runs as :meth:`forward` up to ``F_d``'s input and
        then through ``F_d``'s encoder only: ``F_d``'s decoder, head and the output steps are skipped. The
        same state, bit for bit (``tests/models/test_training_paths.py``). Where the output itself is state
        (``method.warp_previous``), outside training (the denoiser's margin) or with gradients on, the whole
        forward runs."""
        if self.warp_previous or not self.training or torch.is_grad_enabled() or not self.sw["SA"]:
            self(x)
            return
        self._run(x, state_only=True)

    def forward(self, x: dict[str, Tensor | None]) -> dict[str, Tensor]:
        return self._run(x, state_only=False)

    def _run(self, x: dict[str, Tensor | None], state_only: bool) -> dict[str, Tensor]:
        """:meth:`forward`; with ``state_only``, :meth:`advance`'s part of it (``F_d``'s encoder)."""
        who = "two_stage"
        with stage("input packing"):
            g = gbuffers(x, who)
            sampler_in = self.sampler_input(x) if self.sampler is not None else None
        out: dict[str, Tensor] = {}
        if self.sampler is not None:
            c1 = need(x, "c1_in", who)
            with stage("F_s"):
                s = self.sampler(sampler_in)
            with stage("adaptive render"):
                stack = stack_buffers(x, self.levels)
                image, m = adaptive_render(s["logits"], c1, stack, x.get("ref"), self.budget)
            ic = compress(image, self.colour)
            smap = [m / (self.budget - 1)] if self.reads_map else []
            feats = [ic, g, *smap]
            if self.sw["KP"]:
                with stage("kernel pool"):
                    hits = ~miss_mask(need(x, "normal", who)) if self.kp_skip_misses else None
                    kp = self.sampler.initial_denoise(s["finest"], s["coarsest"], g, ic, self.kp_ceiling,
                                                      hits)
                feats = [kp["initial"], *([ic] if self.reads_adaptive else []), g, *smap]
                out["kernel_map"] = kp["kernel_map"].float()
                if not self.training:  # a picture of this frame's adjusted pool for the samples
                    out["kernel_pool"] = pool_picture(kp["pool"], self.sampler.pool.size)
                out["initial"] = expand(kp["initial"], self.colour)
            out["sampling_map"] = m
            out["adaptive"] = image
        else:
            feats = [compress(need(x, uniform_buffer(self.budget), who), self.colour), g]
        if self.warp_previous:
            feats = [*feats, self.previous(x, feats[0].float())]
        with stage("input packing"):
            z = cat_channels([f.float() for f in feats])
        if state_only:  # training, so no margin: F_d reads z as it is
            with stage("F_d"):
                self.denoiser.unet.encode(z)
            return out
        with stage("F_d"):
            y = self.denoise(z)
            if self.residual:
                y = (grey_correction(y) if self.grey_residual else y) + feats[0].float()
        if self.warp_previous:
            self.prev = y
        with stage("output steps"):
            out["output"] = expand(y, self.colour)
            if self.hue_from_ibar:
                out["output"] = hue_from(out["output"], out["initial"])
        return out


#: Its catalogue entries (mcd.config.methods.Method's fields; read from this file without importing it,
#: docs/architecture.md "Methods"): F, the full method (Table 1's "Ours"), its variants, and the component
#: rows the training bench measures (rows A-M: conf/experiment/<row>.yaml, mcd.config.methods.COMPONENTS).
ENTRIES = (
    {"experiment": "F", "display": "Ours (F)", "table1": True, "bench": True, "train_bench": True,
     "paper": {"psnr": 33.39, "ssim": 87.65, "gmacs": 478.22, "params_m": 1.285}},
    {"experiment": "F_paper", "display": "Ours (F, paper's text)", "variant_of": "F"},
    {"experiment": "F_pixel_switch", "display": "F, per-pixel identity channel", "variant_of": "F"},
    {"experiment": "F_hue", "display": "F, hue from i_bar (not the paper's)", "variant_of": "F"},
    {"experiment": "F_hue_grey", "display": "F, hue from i_bar, grey correction (not the paper's)",
     "variant_of": "F"},
    {"experiment": "F_warp_previous", "display": "F + warped previous output (not the paper's)",
     "variant_of": "F", "diagnostic": True},
    {"experiment": "F_he", "display": "F, He's initialisation (diagnostic)", "variant_of": "F",
     "diagnostic": True},
    {"experiment": "F_paper_output", "display": "F, paper's text: F_d predicts the image", "variant_of": "F",
     "diagnostic": True},
    {"experiment": "F_paper_mean", "display": "F, paper's text: no frame-mean match", "variant_of": "F",
     "diagnostic": True},
    {"experiment": "F_paper_bound", "display": "F, paper's text: no output bound", "variant_of": "F",
     "diagnostic": True},
    {"experiment": "F_paper_misses", "display": "F, paper's text: misses through F_d", "variant_of": "F",
     "diagnostic": True},
    {"experiment": "F_paper_edge", "display": "F, paper's text: no edge margin", "variant_of": "F",
     "diagnostic": True},
    {"experiment": "F_paper_map_input", "display": "F, paper's text: F_d without the map", "variant_of": "F",
     "diagnostic": True},
    {"experiment": "F_paper_padding", "display": "F, paper's text: F_s zero padding", "variant_of": "F",
     "diagnostic": True},
    {"experiment": "F_paper_head", "display": "F, paper's text: tanh head", "variant_of": "F",
     "diagnostic": True},
    {"experiment": "F_paper_range", "display": "F, paper's text: pool filters all values", "variant_of": "F",
     "diagnostic": True},
    {"experiment": "F_paper_flips", "display": "F, paper's text: no flips, transposes", "variant_of": "F",
     "diagnostic": True},
    {"experiment": "F_paper_reverse", "display": "F, paper's text: no reversed clips", "variant_of": "F",
     "diagnostic": True},
    {"experiment": "A", "display": "A", "train_bench": True},
    {"experiment": "C", "display": "C", "train_bench": True},
)


@register("two_stage")
def build_two_stage(*, budget: float, UN: bool, AS: bool, KP: bool, PP: bool, FG: bool, SA: bool,
                    denoiser: dict, sampler: dict, kernel_pool: dict, ghost: dict, pooling: dict,
                    attention: dict, sampling: dict, kp: dict, denoiser_output: str, sampler_padding: str,
                    colour: str = "log1p", denoiser_reads_map: bool = False,
                    warp_previous: bool = False, init: str = "torch", denoiser_hue: str = "free") -> TwoStage:
    """``TwoStage`` at ``budget`` (average spp) from its method settings (conf/method/two_stage.yaml): the
    switches ``UN AS KP PP FG SA`` (an impossible combination is refused: mcd.models.switches),
    ``sampling.levels`` (5), ``colour``, ``kp`` (kernel-pool options, docs/kernel_pool.md),
    ``denoiser_output``, ``sampler_padding`` (``F_s``'s convolutions), ``denoiser_reads_map`` (false:
    the paper's list of ``F_d``'s inputs, the default; true: ``F_d`` also reads the normalised sampling map
    with AS, an addition measured without gain, docs/method.md "F against the paper"),
    ``warp_previous`` (a diagnostic, not the paper's: ``F_d`` also reads its warped previous output),
    ``denoiser_hue`` (``free``, the paper; ``i_bar`` or ``i_bar_grey``, not the paper's: the output's hue
    from the pool's; with ``i_bar_grey`` ``F_d``'s correction is grey),
    ``init`` (the convolutions' initialisation, :mod:`mcd.models.init`); and its
    widths (``capacity.two_stage``, conf/capacity/): ``denoiser`` (F_d's level widths and convs per level),
    ``sampler`` (F_s's), ``kernel_pool``, ``ghost`` (the Fast GhostConv's large kernel, groups, mid ratio),
    ``pooling``, ``attention`` (docs/method.md). The output steps and ``F_d``'s margin outside training
    (``method.denoiser_margin``) are :func:`mcd.models.registry.build`'s."""
    switches = check_switches({"UN": UN, "AS": AS, "KP": KP, "PP": PP, "FG": FG, "SA": SA}, complete=True)
    sizes = {"denoiser": denoiser, "sampler": sampler, "kernel_pool": kernel_pool, "ghost": ghost,
             "pooling": pooling, "attention": attention}
    return TwoStage(switches, budget, sizes, levels=int(sampling["levels"]), colour=colour,
                    kp=kp, denoiser_output=str(denoiser_output), sampler_padding=str(sampler_padding),
                    reads_map=bool(denoiser_reads_map),
                    warp_previous=bool(warp_previous), init=str(init), hue=str(denoiser_hue))

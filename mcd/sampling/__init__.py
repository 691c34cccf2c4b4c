"""Adaptive sampling (docs/method.md "Adaptive sampling"): map normalisation, simulated render, DASR gradient.

The true adaptive Mitsuba render of a sampling map lives in :mod:`mcd.data.spp_map_render`.
"""

from mcd.sampling.dasr_grad import AdaptiveRender, adaptive_render
from mcd.sampling.normalise import cap_for_levels, check_logits, frame_budget, normalise_map, shares
from mcd.sampling.real import active_renderer, real_renderer
from mcd.sampling.simulate import blend_with_c1, sample_sum, simulated_render, stack_buffers, stack_names

__all__ = [
    "AdaptiveRender", "active_renderer", "adaptive_render", "blend_with_c1", "cap_for_levels", "check_logits",
    "frame_budget", "real_renderer",
    "normalise_map", "sample_sum", "shares", "simulated_render", "stack_buffers", "stack_names",
]

"""The adaptive render as a differentiable step (docs/method.md "Adaptive sampling" step 4, DASR's
approximation).

Rounding the map and picking renders by the bits of ``m`` have no useful derivative. DASR approximates the
change of a pixel's ``1 + m`` sample average with one more sample by ``(ref - i) / (1 + m)`` (the expected
step towards the converged value), so in backward ``dL/dm_p = sum_c dL/di_p,c * (ref_p,c - i_p,c) / (1 +
m_p)``; ``m = p * N * (s - 1)`` before rounding gives ``dL/dp = dL/dm * N * (s - 1)``, and autograd takes it
through the softmax to the logits. A pixel at the per-pixel cap gets ``dL/dm_p = 0``: ``m = min(lam p, cap)``
does not grow with its share there. DASR's estimate, ``(ref - i) / (1 + m)``, says one more sample helps
whether or not the pixel can take it, so without the cap's zero derivative a capped pixel's logit is pushed
up at every step for nothing; where the cap binds (at 32 spp it is only 2x the mean) the logits then drift
apart without bound and the softmax ends one-hot (docs/method.md "Adaptive sampling", step 4). ``ref`` is
read only here. The map itself is returned as a non-differentiable output: feeding it to the denoiser sends
no gradient back to the sampler (the paper's gradient is the only path).
"""

from __future__ import annotations

import torch
from torch import Tensor

from mcd.core.stages import stage
from mcd.sampling.normalise import cap_for_levels, frame_budget, normalise_map, shares
from mcd.sampling.real import active_renderer
from mcd.sampling.simulate import blend_with_c1


class AdaptiveRender(torch.autograd.Function):
    """``(p, c1, stack, ref, budget) -> (i, m)``; see the module docstring for the backward pass."""

    @staticmethod
    def forward(ctx, p: Tensor, c1: Tensor, stack: Tensor, ref: Tensor | None, budget: float):
        cap = cap_for_levels(stack.shape[1] - 1)
        with stage("map normalisation"):
            m = normalise_map(p, budget, cap)
        i = blend_with_c1(c1.float(), m.float(), stack.float())
        ctx.mark_non_differentiable(m)
        ctx.budget, ctx.cap = budget, cap
        ctx.save_for_backward(i, m, ref)
        return i, m

    @staticmethod
    def backward(ctx, grad_i: Tensor, _grad_m: Tensor | None):
        i, m, ref = ctx.saved_tensors
        if ref is None:
            raise RuntimeError("the adaptive render's gradient (DASR) needs the reference: pass x['ref'] "
                               "during training (it may be None only when no gradient is taken)")
        dm = (grad_i.float() * (ref.float() - i) / (1 + m)).sum(1, keepdim=True)
        dm = dm.masked_fill(m >= ctx.cap, 0.0)  # the cap's derivative: a capped pixel gains no sample
        n = m[0].numel()
        dp = dm * float(frame_budget(n, ctx.budget))
        return dp, None, None, None, None


def adaptive_render(logits: Tensor, c1: Tensor, stack: Tensor, ref: Tensor | None,
                    budget: float) -> tuple[Tensor, Tensor]:
    """Sampling logits ``[B,1,H,W]`` -> (adaptive image ``i`` ``[B,3,H,W]``, sampling map ``m``
    ``[B,1,H,W]``).

    ``c1`` is the render the sampler saw (``c1_in``), ``stack`` the ``[B, K, 3, H, W]`` renders ``c_{2^k}``,
    ``ref`` the reference (training only). Computed in fp32 whatever the autocast state. On the meta device
    (MAC counting, :mod:`mcd.models.complexity`) only shapes are produced: these steps hold no
    multiply-accumulates.
    Inside :func:`mcd.sampling.real.real_renderer` the map is rendered for real (``stack`` is not read).
    """
    if logits.device.type == "meta":
        return c1.float().clone(), logits.float().clone()
    with torch.autocast(device_type=logits.device.type, enabled=False):
        p = shares(logits)
        render_sum = active_renderer()
        if render_sum is not None:
            m = normalise_map(p, budget, cap_for_levels(stack.shape[1] - 1))
            return (c1.float() + render_sum(m).float()) / (1 + m.float()), m
        return AdaptiveRender.apply(p, c1, stack, ref, budget)

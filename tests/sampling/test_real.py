"""``mcd.sampling.real_renderer``: the adaptive render of a map by a renderer instead of the stored stack
(docs/denoise.md). Fed the stack's own sample sums, it must reproduce the simulated render exactly."""

from __future__ import annotations

import torch

from mcd.sampling import adaptive_render, real_renderer, sample_sum


def test_real_renderer_replaces_the_stack_and_keeps_the_map():
    g = torch.Generator().manual_seed(0)
    logits = torch.randn(1, 1, 8, 8, generator=g)
    c1 = torch.rand(1, 3, 8, 8, generator=g)
    stack = torch.rand(1, 6, 3, 8, 8, generator=g)
    i_sim, m_sim = adaptive_render(logits, c1, stack, None, 4.0)
    calls = []

    def render_sum(m: torch.Tensor) -> torch.Tensor:
        calls.append(m.clone())
        return sample_sum(m, stack)

    with real_renderer(render_sum):
        i_real, m_real = adaptive_render(logits, c1, torch.zeros_like(stack), None, 4.0)
    assert len(calls) == 1 and torch.equal(calls[0], m_sim)
    assert torch.equal(m_real, m_sim) and int(m_real.sum()) == 64 * 3
    torch.testing.assert_close(i_real, i_sim)
    i_after, _ = adaptive_render(logits, c1, stack, None, 4.0)  # outside the block: simulated again
    torch.testing.assert_close(i_after, i_sim)

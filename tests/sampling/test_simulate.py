"""Simulated adaptive render = the average of exactly the samples the map asks for (docs/method.md AS 2-3)."""

import pytest
import torch

from mcd.sampling import blend_with_c1, sample_sum, simulated_render, stack_buffers


def _samples_and_stack(levels: int = 5, shape=(2, 3, 6, 7)):
    """Per-pixel samples and the renders c_{2^k} made of disjoint groups of them (HDR-ish values)."""
    torch.manual_seed(1)
    n = 2 ** (levels + 1) - 1
    samples = torch.rand(shape[0], n, *shape[1:], dtype=torch.float64) ** 4 * 100
    groups, start = [], 0
    for k in range(levels + 1):
        groups.append(range(start, start + 2 ** k))
        start += 2 ** k
    stack = torch.stack([samples[:, list(g)].mean(1) for g in groups], 1)
    return samples, stack, groups


def test_simulated_render_equals_direct_average_of_the_same_samples():
    samples, stack, groups = _samples_and_stack()
    b, _, c, h, w = samples.shape
    m = torch.randint(0, 64, (b, 1, h, w)).double()
    got = simulated_render(m, stack)
    want = torch.zeros(b, c, h, w, dtype=torch.float64)
    for bi in range(b):
        for y in range(h):
            for x in range(w):
                mm = int(m[bi, 0, y, x])
                chosen = [j for k, g in enumerate(groups) if (mm >> k) & 1 for j in g]
                assert len(chosen) == mm
                if chosen:
                    want[bi, :, y, x] = samples[bi, chosen, :, y, x].mean(0)
    torch.testing.assert_close(got, want)


def test_blend_with_c1_is_the_average_of_one_plus_m_samples():
    samples, stack, groups = _samples_and_stack()
    c1 = torch.rand_like(stack[:, 0]) * 10                  # the sampler's own 1 spp render
    m = torch.randint(0, 64, (2, 1, 6, 7)).double()
    m[0, 0, 0, 0] = 0
    got = blend_with_c1(c1, m, stack)
    want = (c1 + simulated_render(m, stack) * m) / (1 + m)
    torch.testing.assert_close(got, want)
    torch.testing.assert_close(got[0, :, 0, 0], c1[0, :, 0, 0])   # zero-spp pixel: c_1 alone
    assert torch.isfinite(got).all()


def test_sample_sum_rejects_counts_beyond_the_stack():
    _, stack, _ = _samples_and_stack(levels=2)
    with pytest.raises(ValueError, match="stack has only 3 levels"):
        sample_sum(torch.full((2, 1, 6, 7), 8.0, dtype=torch.float64), stack)


def test_stack_buffers_names_missing_buffers():
    x = {f"c{2 ** k}": torch.zeros(1, 3, 4, 4) for k in range(5)}
    with pytest.raises(KeyError, match="c32"):
        stack_buffers(x, 5)


def test_stack_buffers_puts_c_2k_at_level_k():
    """Each buffer filled with its own spp, given in a shuffled dict order: level k must hold c_{2^k}."""
    names = ["c8", "c1", "c32", "c4", "c16", "c2", "ref"]
    x = {n: torch.full((2, 3, 4, 4), float(n[1:]) if n != "ref" else -1.0) for n in names}
    stack = stack_buffers(x, 5)
    assert stack.shape == (2, 6, 3, 4, 4)
    assert stack[:, :, 0, 0, 0].tolist() == [[1.0, 2.0, 4.0, 8.0, 16.0, 32.0]] * 2
    m = torch.full((2, 1, 4, 4), 5.0)  # bits 0 and 2: one sample of c1 and four of c4
    torch.testing.assert_close(sample_sum(m, stack), torch.full((2, 3, 4, 4), 1.0 * 1 + 4.0 * 4))

"""The DASR gradient of the adaptive render (method.md AS step 4): formula, sign and scale."""

import pytest
import torch

from mcd.sampling import AdaptiveRender, adaptive_render, frame_budget, shares


def _toy(h=4, w=4):
    """Left half: every render is off the reference by 1/sqrt(spp) (its noise level), so every extra sample
    provably brings the average closer; right half: renders equal to the reference (samples are wasted)."""
    ref = torch.full((1, 3, h, w), 0.5)
    error = torch.zeros(1, 6, 3, h, w)
    error[..., : w // 2] = 1.0
    stack = ref[:, None] + error / torch.tensor([1, 2, 4, 8, 16, 32.0]).sqrt().view(1, 6, 1, 1, 1)
    c1 = ref + error[:, 0]
    return c1, stack, ref


def test_backward_is_the_dasr_formula():
    c1, stack, ref = _toy()
    logits = torch.randn(1, 1, 4, 4, requires_grad=True)
    p = shares(logits)
    p.retain_grad()
    i, m = AdaptiveRender.apply(p, c1, stack, ref, 4.0)
    weight = torch.randn_like(i)
    (i * weight).sum().backward()
    want = (weight * (ref - i.detach()) / (1 + m)).sum(1, keepdim=True) * frame_budget(16, 4.0)
    torch.testing.assert_close(p.grad, want)
    assert not m.requires_grad, "the map is a non-differentiable output"


def test_sign_more_samples_where_they_help():
    c1, stack, ref = _toy()
    logits = torch.zeros(1, 1, 4, 4, requires_grad=True)
    i, _ = adaptive_render(logits, c1, stack, ref, 4.0)
    ((i - ref) ** 2).sum().backward()
    grad = logits.grad[0, 0]
    assert bool((grad[:, :2] < 0).all()), "noisy pixels: raising their logit lowers the loss"
    assert bool((grad[:, 2:] > 0).all()), "converged pixels: their samples are better spent elsewhere"


def test_scale_matches_the_expected_loss_derivative():
    """For i = mean of 1+m samples with variance s2, E[(i - ref)^2] = s2 / (1 + m), whose derivative is
    -s2 / (1 + m)^2. DASR's first-order estimate -2 (i - ref)^2 / (1 + m) has expectation exactly twice that
    (the neglected second-order term is the new sample's own variance): check sign and factor 2."""
    torch.manual_seed(3)
    trials, s2, m_val = 20000, 0.25, 3
    samples = torch.randn(trials, 1 + m_val) * s2 ** 0.5
    i = samples.mean(1)
    ref = torch.zeros(())
    estimate = (2 * (i - ref) * (ref - i) / (1 + m_val)).mean()
    exact = -s2 / (1 + m_val) ** 2
    assert estimate < 0
    assert estimate / exact == pytest.approx(2.0, rel=0.05)


def test_backward_without_reference_says_so():
    c1, stack, _ = _toy()
    logits = torch.zeros(1, 1, 4, 4, requires_grad=True)
    i, _ = adaptive_render(logits, c1, stack, None, 4.0)
    with pytest.raises(RuntimeError, match="needs the reference"):
        i.sum().backward()


def test_training_improves_the_map_on_the_toy():
    """A few steps of gradient descent on the logits move samples to the noisy half and lower the loss."""
    c1, stack, ref = _toy(8, 8)
    logits = torch.zeros(1, 1, 8, 8, requires_grad=True)
    opt = torch.optim.Adam([logits], lr=0.2)
    losses = []
    for _ in range(30):
        opt.zero_grad()
        i, m = adaptive_render(logits, c1, stack, ref, 4.0)
        loss = ((i - ref) ** 2).mean()
        loss.backward()
        opt.step()
        losses.append(float(loss.detach()))
    assert float(m[..., :4].sum()) > 0.9 * float(m.sum())
    assert losses[-1] < 0.6 * losses[0]

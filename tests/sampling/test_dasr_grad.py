"""The DASR gradient of the adaptive render (docs/method.md AS step 4): formula, sign and scale."""

import pytest
import torch

from mcd.sampling import AdaptiveRender, adaptive_render, frame_budget


def _toy(h=4, w=4):
    """Left half: every render is off the reference by 1/sqrt(spp) (its noise level), so every extra sample
    provably brings the average closer; right half: renders equal to the reference (samples are wasted)."""
    ref = torch.full((1, 3, h, w), 0.5)
    error = torch.zeros(1, 6, 3, h, w)
    error[..., : w // 2] = 1.0
    stack = ref[:, None] + error / torch.tensor([1, 2, 4, 8, 16, 32.0]).sqrt().view(1, 6, 1, 1, 1)
    c1 = ref + error[:, 0]
    return c1, stack, ref


def test_backward_on_a_hand_worked_two_pixel_frame():
    """Two pixels, budget 4 (6 samples, m = 3 each), ref 0.5; c1 and the stack are 1.0 on the left, 0.5 on the
    right (c1_in 1.0 everywhere), so i = (1 + 3 * 1) / 4 = 1 and (1 + 3 * 0.5) / 4 = 0.625. With L = sum(i),
    dL/dm = 3 channels x (0.5 - i) / (1 + 3) = -0.375 and -0.09375, and dL/dp = dL/dm x N (s - 1) = x 6."""
    ref = torch.full((1, 3, 1, 2), 0.5)
    c1 = torch.ones(1, 3, 1, 2)
    stack = torch.ones(1, 6, 3, 1, 2)
    stack[..., 1] = 0.5
    p = torch.full((1, 1, 1, 2), 0.5, requires_grad=True)
    i, m = AdaptiveRender.apply(p, c1, stack, ref, 4.0)
    torch.testing.assert_close(m, torch.full((1, 1, 1, 2), 3.0))
    torch.testing.assert_close(i[0, :, 0], torch.tensor([[1.0, 0.625]] * 3))
    i.sum().backward()
    torch.testing.assert_close(p.grad, torch.tensor([[[[-2.25, -0.5625]]]]))
    assert not m.requires_grad, "the map is a non-differentiable output"


def test_backward_of_a_batch_equals_each_frame_alone():
    """Frames of a batch are normalised and differentiated independently (each spends its own budget)."""
    torch.manual_seed(0)
    c1, stack, ref = (torch.rand(2, *shape) for shape in ((3, 4, 4), (6, 3, 4, 4), (3, 4, 4)))
    logits = torch.randn(2, 1, 4, 4, requires_grad=True)
    weight = torch.randn(2, 3, 4, 4)
    i, m = adaptive_render(logits, c1, stack, ref, 4.0)
    (i * weight).sum().backward()
    for b in range(2):
        one = logits[b : b + 1].detach().clone().requires_grad_(True)
        i_b, m_b = adaptive_render(one, c1[b : b + 1], stack[b : b + 1], ref[b : b + 1], 4.0)
        (i_b * weight[b : b + 1]).sum().backward()
        torch.testing.assert_close(i[b : b + 1], i_b)
        torch.testing.assert_close(m[b : b + 1], m_b)
        torch.testing.assert_close(logits.grad[b : b + 1], one.grad)
        assert float(m_b.sum()) == frame_budget(16, 4.0)


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
    (the neglected second-order term is the new sample's own variance): check sign and factor 2 on the
    package's backward, over 64x64 pixels x 3 channels whose c_1_in and c_{2^k} carry noise of variance
    s2 / 2^k (uniform map, m = 3: c_1_in + c_1 + c_2 = 4 samples)."""
    torch.manual_seed(3)
    h = w = 64
    s2, budget = 0.25, 4.0
    ref = torch.zeros(1, 3, h, w)
    spp = torch.tensor([1, 2, 4, 8, 16, 32.0]).view(1, 6, 1, 1, 1)
    stack = torch.randn(1, 6, 3, h, w) * (s2 / spp).sqrt()
    c1 = torch.randn(1, 3, h, w) * s2 ** 0.5
    p = torch.full((1, 1, h, w), 1 / (h * w), requires_grad=True)
    i, m = AdaptiveRender.apply(p, c1, stack, ref, budget)
    assert bool((m == 3).all())
    ((i - ref) ** 2).sum().backward()
    per_sample = p.grad / frame_budget(h * w, budget) / 3   # dL/dm per pixel and channel
    estimate = float(per_sample.mean())
    exact = -s2 / (1 + 3) ** 2
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


def test_a_capped_pixel_gets_no_gradient_and_logits_stay_bounded_where_the_cap_binds():
    """At 32 spp the cap (63) is only 2x the mean: a quarter of the frame that needs every sample it can get
    sits at the cap. DASR's estimate says one more sample would still help there; the cap's zero derivative
    keeps that from pushing the capped pixels' logits up at every step. Without it their logits drifted
    apart without bound (spread 7.6 after 100 Adam steps, 9.1 after 400 and growing), the failure the
    converged 32-spp F showed as logits spanning -98..+31 on one test frame and a one-hot softmax."""
    h = w = 8
    ref = torch.full((1, 3, h, w), 0.5)
    error = torch.full((1, 6, 3, h, w), 0.1)
    error[..., :2] = 1.0                                  # two noisy columns, the rest nearly converged
    stack = ref[:, None] + error / torch.tensor([1, 2, 4, 8, 16, 32.0]).sqrt().view(1, 6, 1, 1, 1)
    c1 = ref + error[:, 0]
    p = torch.full((1, 1, h, w), 1 / (h * w))
    p[..., :2] *= 5
    p = (p / p.sum()).requires_grad_(True)
    i, m = AdaptiveRender.apply(p, c1, stack, ref, 32.0)
    assert bool((m[..., :2] == 63).all()) and not bool((m[..., 2:] == 63).any())
    ((i - ref) ** 2).sum().backward()
    assert bool((p.grad[..., :2] == 0).all()) and bool((p.grad[..., 2:] < 0).all())
    logits = torch.zeros(1, 1, h, w, requires_grad=True)
    opt = torch.optim.Adam([logits], lr=0.2)
    spreads = []
    for _ in range(400):
        opt.zero_grad()
        i, m = adaptive_render(logits, c1, stack, ref, 32.0)
        ((i - ref) ** 2).mean().backward()
        opt.step()
        spreads.append(float(logits.detach().max() - logits.detach().min()))
    assert bool((m[..., :2] == 63).all()), "the noisy columns still get every sample the cap allows"
    assert spreads[-1] < 3.0 and spreads[-1] <= spreads[99]

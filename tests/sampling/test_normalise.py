"""Sampling-map normalisation: the exact budget per frame, the cap, and bad logits (docs/method.md
"Adaptive sampling" step 1)."""

import pytest
import torch

from mcd.sampling import cap_for_levels, frame_budget, normalise_map, shares


def _check(m: torch.Tensor, budget: float, cap: int = 63) -> None:
    n = m[0].numel()
    assert torch.equal(m, m.round()), "the map holds integers"
    assert int(m.min()) >= 0 and int(m.max()) <= cap
    for frame in m:
        assert int(frame.sum()) == frame_budget(n, budget)


@pytest.mark.parametrize("budget", [2, 4, 8, 32, 64, 3.5, 2.25, 7.3])  # non-integer: round(N (s - 1))
@pytest.mark.parametrize("scale", [0.0, 1.0, 5.0, 40.0])
def test_budget_invariant_on_random_logits(budget, scale):
    torch.manual_seed(budget * 10 + int(scale))
    logits = torch.randn(3, 1, 17, 23) * scale
    m = normalise_map(shares(logits), budget)
    _check(m, budget)


def test_a_non_integer_budget_spends_its_exact_rounded_sum():
    """17 x 23 = 391 pixels at s = 3.5: round(391 * 2.5) = round(977.5) = 978 samples (Python rounds half to
    even), neither 977 nor the 1173 of the integer budget 4."""
    assert frame_budget(391, 3.5) == 978
    m = normalise_map(shares(torch.randn(2, 1, 17, 23)), 3.5)
    assert [int(f.sum()) for f in m] == [978, 978]


@pytest.mark.parametrize("big", [1e4, -1e4])
def test_extreme_logits_keep_the_budget_and_the_cap(big):
    logits = torch.zeros(2, 1, 32, 32)
    logits[:, :, :3, :5] = big                       # +1e4: one-hot shares, the cap must spread the samples
    m = normalise_map(shares(logits), 4)
    _check(m, 4)
    if big > 0:
        assert bool((m[:, :, :3, :5] == 63).all()), "the favoured pixels are filled up to the cap"
        rest = (3 * 1024 - 15 * 63) / (1024 - 15)      # the excess spreads evenly over the others
        others = m.clone()
        others[:, :, :3, :5] = rest
        assert float((others - rest).abs().max()) < 1


def test_rounding_is_proportional_where_no_cap_binds():
    torch.manual_seed(0)
    p = shares(torch.randn(1, 1, 20, 20) * 0.5)
    m = normalise_map(p, 4)
    ideal = p.double() * frame_budget(400, 4)
    assert float((m.double() - ideal).abs().max()) < 1.0


def test_cap_is_water_filled_in_proportion():
    """Capped pixels give their excess to the others in proportion to their shares."""
    p = torch.tensor([0.5, 0.3, 0.1, 0.1]).view(1, 1, 2, 2)
    m = normalise_map(p, 64, cap=63)                 # 4 * 63 = 252 samples, all pixels at the cap
    assert m.flatten().tolist() == [63, 63, 63, 63]
    m = normalise_map(p, 41, cap=63)                 # 160 samples: 80 -> 63 capped, 97 split 3:1:1
    assert m.flatten().tolist()[0] == 63 and int(m.sum()) == 160
    assert abs(m.flatten()[1].item() - 97 * 0.6) <= 1 and abs(m.flatten()[2].item() - 97 * 0.2) <= 1


@pytest.mark.parametrize("bad", [float("nan"), float("inf")])
def test_nan_or_inf_logits_raise(bad):
    logits = torch.zeros(1, 1, 8, 8)
    logits[0, 0, 3, 3] = bad
    with pytest.raises(ValueError, match="NaN/Inf"):
        shares(logits)
    with pytest.raises(ValueError, match="NaN/Inf"):
        normalise_map(torch.full((1, 1, 4, 4), float("nan")), 4)


def test_budget_beyond_the_cap_raises():
    p = shares(torch.zeros(1, 1, 4, 4))
    with pytest.raises(ValueError, match="more than the cap"):
        normalise_map(p, 65, cap=cap_for_levels(5))
    assert cap_for_levels(5) == 63

"""The ``noisy`` row: the uniform render at the budget, unchanged, no parameters."""

from __future__ import annotations

import pytest
import torch

from mcd.models.baselines.noisy import Noisy

from .helpers import frame


def test_noisy_returns_the_uniform_render_at_the_budget() -> None:
    x = frame()
    m = Noisy(8)
    assert m.required_buffers() == {"c8"} and sum(p.numel() for p in m.parameters()) == 0
    out = m(x)["output"]
    assert torch.equal(out, x["c8"]) and out is not x["c8"]


def test_budget_without_a_uniform_render_is_an_error() -> None:
    with pytest.raises(ValueError, match="budget=6"):
        Noisy(6)

"""Timing models in turn (mcd/models/latency.py ``alternated_ms``, the report's speed-against-error points,
docs/benchmark.md "Reports"): every round times one frame of every model, so a change of the machine's load
falls on all of them alike; a model that fails is its own entry's reason and leaves the others' times."""

from __future__ import annotations

import math

import torch

from mcd.config.compose import compose
from mcd.models import build
from mcd.models.latency import FrameTimer, alternated_ms


def _model(experiment: str) -> torch.nn.Module:
    return build(compose([f"+experiment={experiment}", "capacity=cpu", "data.height=24", "data.width=20"]))


def test_the_models_are_timed_in_turn_one_frame_each_per_round():
    models = {"A": _model("A"), "F": _model("F")}
    order: list[str] = []
    for name, model in models.items():
        model.register_forward_pre_hook(lambda _m, _a, name=name: order.append(name))
    times = alternated_ms([FrameTimer(m, 24, 20) for m in models.values()], warmup=2, reps=3)
    assert order == ["A", "A", "F", "F"] + ["A", "F"] * 3  # the warm-up per model, then alternating rounds
    assert all(isinstance(t, float) and t > 0 for t in times)


def test_a_model_with_a_non_finite_output_is_named_and_the_others_are_timed():
    bad, good = _model("A"), _model("A")

    def poison(_m, _a, out):
        out["output"] = torch.full_like(out["output"], math.nan)
        return out

    bad.register_forward_hook(poison)
    first, second = alternated_ms([FrameTimer(bad, 24, 20), FrameTimer(good, 24, 20)], warmup=1, reps=2)
    assert isinstance(first, FloatingPointError)
    assert "non-finite output" in str(first) and "20x24" in str(first)
    assert isinstance(second, float) and second > 0

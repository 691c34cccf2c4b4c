"""``tools/sampler_trace.py`` (docs/method.md "Initialisation"): ``F_s``'s state on seeded inputs tells a
constant sampling network from a live one, and the trace writes one row per ``--every`` optimiser steps of a
real training on the session's Cornell-box store."""

from __future__ import annotations

import csv

import pytest
import torch

from tests.conftest import store32_overrides
from tools.sampler_trace import main, sampler_state


def _built(*overrides: str, seed: int) -> torch.nn.Module:
    from mcd.config.compose import compose
    from mcd.models.registry import build

    torch.manual_seed(seed)
    return build(compose(["+experiment=F", "data=tiny", *overrides]))


def test_torch_init_starts_constant_and_he_alive():
    state = sampler_state(_built("method.init=torch", seed=2), budget=4.0, size=32)
    assert state["logits_std"] < 1e-5 and state["map_spread"] == 0.0 and state["first_constant"]
    assert state["map_min"] == state["map_max"] == 3.0  # 1 + 3 adaptive samples on every pixel at 4 spp
    state = sampler_state(_built("method.init=he", seed=2), budget=4.0, size=32)
    assert state["logits_std"] > 1e-2 and state["map_spread"] > 0 and state["first_constant"] == ""


@pytest.mark.slow
def test_the_trace_of_a_real_training(cbox_store, tmp_path):
    cfg, _ = cbox_store
    out = tmp_path / "trace.csv"
    overrides = [*store32_overrides(cfg.paths.data_dir), "+experiment=F", "train.max_steps=3",
                 "train.epochs=null", "train.max_minutes=null", "train.batch_size=1",
                 "trainer.enable_progress_bar=false"]
    assert main(["--out", str(out), "--every", "2", "--run-dir", str(tmp_path / "run"), *overrides]) == 0
    rows = list(csv.DictReader(out.open()))
    assert [int(r["step"]) for r in rows] == [0, 2]
    assert all(float(r["grad_denoiser"]) > 0 and float(r["grad_sampler"]) > 0 for r in rows)
    assert all(r["dead_units"].split("/")[1] == rows[0]["dead_units"].split("/")[1] for r in rows)
    assert main(["--out", str(out), "+experiment=A", *store32_overrides(tmp_path)]) == 2  # no F_s: refused

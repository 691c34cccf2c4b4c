"""Every baseline composes from ``+experiment=<name>``, builds through the registry, selects its own loss,
and at the ``paper`` capacity profile lands within 10% of Table 1's params and 1080p MACs
(docs/baselines.md)."""

from __future__ import annotations

import importlib.util

import pytest
import torch
from omegaconf import OmegaConf

from mcd.config.compose import compose
from mcd.config.methods import TABLE1
from mcd.losses import build_loss
from mcd.models import build
from mcd.models.complexity import complexity, dummy_batch

FIVE = ("unet", "rae", "fastdvdnet", "dasr", "ntasad")
LOSS = {"unet": "paper", "rae": "rae", "fastdvdnet": "mse", "dasr": "dasr", "ntasad": "ntasad",
        "oidn": "paper", "noisy": "paper"}
HAS_PYOIDN = importlib.util.find_spec("pyoidn") is not None


@pytest.mark.parametrize("name", [*FIVE, "noisy", "oidn"])
def test_experiment_builds_its_method_and_loss_and_runs_a_frame(name: str) -> None:
    if name == "oidn" and not HAS_PYOIDN:
        pytest.skip("pyoidn is not installed (optional: pip install 'mcd[oidn]')")
    cfg = compose([f"+experiment={name}", "capacity=cpu"])
    assert cfg.experiment == name and cfg.method.name == name
    assert cfg.method.get("trainable", True) is (name not in ("oidn", "noisy"))
    assert cfg.loss.name == LOSS[name] and build_loss(cfg) is not None
    torch.manual_seed(0)
    model = build(cfg).eval()
    x = dummy_batch(model, 24, 40, "cpu")
    with torch.no_grad():
        out = model(x)["output"]
    assert out.shape == (1, 3, 24, 40) and torch.isfinite(out).all()
    if name in ("oidn", "noisy"):
        assert sum(p.numel() for p in model.parameters()) == 0


def test_unet_is_component_row_a() -> None:
    unet = build(compose(["+experiment=unet", "capacity=paper"]))
    row_a = build(compose(["+experiment=A", "capacity=paper"]))
    assert type(unet) is type(row_a)
    assert [tuple(p.shape) for p in unet.parameters()] == [tuple(p.shape) for p in row_a.parameters()]
    cfg = compose(["+experiment=unet", "capacity=cpu"])
    cfg.method.AS = True
    with pytest.raises(ValueError, match="row A"):
        build(cfg)


def test_baselines_own_loss_or_the_papers() -> None:
    cfg = compose(["+experiment=rae", "loss=paper"])
    assert cfg.loss.name == "paper" and cfg.method.name == "rae"


@pytest.mark.parametrize("name", FIVE)
def test_paper_profile_matches_table1_within_10_percent(name: str) -> None:
    cfg = compose([f"+experiment={name}", "capacity=paper"])
    params_m, gmacs = complexity(cfg)
    paper = TABLE1[name]
    assert abs(params_m / paper["params_m"] - 1) < 0.10, f"{name}: {params_m:.3f} M vs {paper['params_m']} M"
    assert abs(gmacs / paper["gmacs"] - 1) < 0.10, f"{name}: {gmacs:.1f} GMACs vs {paper['gmacs']}"


def test_cpu_profile_is_much_smaller_than_paper() -> None:
    """About a fifth of the paper's size (equal MAC shares: tests/models/test_capacity_shares.py)."""
    for name in FIVE[1:]:
        small = build(compose([f"+experiment={name}", "capacity=cpu"]))
        n = sum(p.numel() for p in small.parameters())
        assert n < 0.3 * TABLE1[name]["params_m"] * 1e6, f"{name}: cpu profile has {n} params"
    assert OmegaConf.select(compose(["+experiment=rae", "capacity=cpu"]), "capacity.rae.encoder") is not None

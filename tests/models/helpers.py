"""Shared helpers of the model tests: configs of the component rows and random frames."""

from __future__ import annotations

from pathlib import Path

import torch
from omegaconf import OmegaConf

from mcd.config.methods import COMPONENTS
from mcd.data.buffers import BUFFERS
from mcd.data.synthetic import synthetic_frame
from mcd.models.switches import SWITCHES

CONF = Path(__file__).resolve().parents[2] / "conf"
#: Row -> its switches as bits (``UN AS KP PP FG SA``), as the rows' files set them
#: (mcd.config.methods.COMPONENTS).
ROWS = {row: "".join("1" if c["switches"][s] else "0" for s in SWITCHES) for row, c in COMPONENTS.items()}


def row_cfg(row: str, profile: str = "cpu", budget: float = 4):
    """The run config of a component row with a capacity profile (conf/method/two_stage.yaml with the row's
    switches, ``conf/experiment/<row>.yaml``, + the profile)."""
    exp = OmegaConf.load(CONF / "experiment" / f"{row}.yaml")
    method = OmegaConf.merge(OmegaConf.load(CONF / "method" / "two_stage.yaml"), exp.method)
    model = OmegaConf.load(CONF / "capacity" / f"{profile}.yaml")
    return OmegaConf.create({"method": method, "budget": budget, "capacity": model})


def switch_cfg(bits: str, profile: str = "cpu", budget: float = 4):
    """The run config of any switches ``bits`` (``UN AS KP PP FG SA``), possible or not: every other key of
    conf/method/two_stage.yaml (the factory's knobs have no defaults of their own), + the profile."""
    switches = {s: b == "1" for s, b in zip(SWITCHES, bits, strict=True)}
    method = OmegaConf.merge(OmegaConf.load(CONF / "method" / "two_stage.yaml"), switches)
    model = OmegaConf.load(CONF / "capacity" / f"{profile}.yaml")
    return OmegaConf.create({"method": method, "budget": budget, "capacity": model})


def frame(h: int = 32, w: int = 32, b: int = 1, scale: float = 1.0, seed: int = 0) -> dict[str, torch.Tensor]:
    """One synthetic frame of every buffer (:func:`mcd.data.synthetic.synthetic_frame`: linear HDR colour up
    to ``scale``, G-buffers in their ranges) with a reference."""
    return synthetic_frame(BUFFERS, h, w, (b,), seed, colour_scale=scale, depth_scale=20.0)

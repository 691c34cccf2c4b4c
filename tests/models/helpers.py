"""Shared helpers of the model tests: configs of the component rows and random frames."""

from __future__ import annotations

from pathlib import Path

import torch
from omegaconf import OmegaConf

from mcd.data.buffers import BUFFERS
from mcd.data.synthetic import synthetic_frame
from mcd.models.switches import SWITCHES

CONF = Path(__file__).resolve().parents[2] / "conf"
ROWS = dict(A="100000", B="110000", C="111000", D="111100", E="111110", F="111111", G="111010", H="111011",
            I="111101", J="111001", K="110100", L="110010", M="110001")


def row_cfg(row: str, profile: str = "cpu", budget: float = 4):
    """The run config of a component row with a capacity profile (conf/method/two_stage.yaml with the
    experiment file's switches + the profile)."""
    exp = OmegaConf.load(CONF / "experiment" / f"{row}.yaml")
    method = OmegaConf.merge(OmegaConf.load(CONF / "method" / "two_stage.yaml"), exp.method)
    model = OmegaConf.load(CONF / "model" / f"{profile}.yaml")
    return OmegaConf.create({"method": method, "budget": budget, "model": model})


def switch_cfg(bits: str, profile: str = "cpu", budget: float = 4):
    method = {"name": "two_stage", **{s: b == "1" for s, b in zip(SWITCHES, bits, strict=True)}}
    model = OmegaConf.load(CONF / "model" / f"{profile}.yaml")
    return OmegaConf.create({"method": method, "budget": budget, "model": model})


def frame(h: int = 32, w: int = 32, b: int = 1, scale: float = 1.0, seed: int = 0) -> dict[str, torch.Tensor]:
    """One synthetic frame of every buffer (:func:`mcd.data.synthetic.synthetic_frame`: linear HDR colour up
    to ``scale``, G-buffers in their ranges) with a reference."""
    return synthetic_frame(BUFFERS, h, w, (b,), seed, colour_scale=scale, depth_scale=20.0)

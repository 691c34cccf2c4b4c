"""Table 1's U-Net = component row A (docs/baselines.md "U-Net"): the project's denoiser ``F_d`` alone on the
uniform render at the budget + G-buffers, single frame, direct RGB output. Same code as row A: a thin alias of
``two_stage`` with the switches ``UN AS KP PP FG SA = 100000`` and the widths of ``capacity.two_stage``."""

from __future__ import annotations

from omegaconf import DictConfig, OmegaConf
from torch import nn

from mcd.models.registry import register
from mcd.models.switches import SWITCHES
from mcd.models.two_stage import build_two_stage

ROW_A = {s: s == "UN" for s in SWITCHES}


@register("unet")
def build_unet(method: DictConfig, model: DictConfig, budget: float) -> nn.Module:
    """Row A of the two-stage model; a switch other than UN turned on is an error (use ``two_stage`` then)."""
    on = [s for s in SWITCHES if s != "UN" and bool(method.get(s, False))]
    if on:
        raise ValueError(f"method.name=unet is component row A (only UN); it cannot take "
                         f"method.{on[0]}=true. Use method=two_stage (conf/method/) for other switch rows, "
                         "or +experiment=unet")
    return build_two_stage(OmegaConf.merge(method, ROW_A), model, budget)

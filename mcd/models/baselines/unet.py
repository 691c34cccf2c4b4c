"""Table 1's U-Net = component row A (docs/baselines.md "U-Net"): the project's denoiser ``F_d`` alone on the
uniform render at the budget + G-buffers, single frame, direct RGB output. Same code as row A: a thin alias of
``two_stage`` with the switches ``UN AS KP PP FG SA = 100000`` and the widths of ``capacity.two_stage``."""

from __future__ import annotations

from typing import Any

from torch import nn

from mcd.models.registry import check_call, register
from mcd.models.switches import SWITCHES
from mcd.models.two_stage import build_two_stage

ROW_A = {s: s == "UN" for s in SWITCHES}


#: Its catalogue entries (mcd.config.methods.Method's fields; read from this file without importing it,
#: docs/architecture.md "Methods").
ENTRIES = (
    {"experiment": "unet", "display": "U-Net", "table1": True, "stand_in": "A", "bench": True,
     "paper": {"psnr": 31.91, "ssim": 86.00, "gmacs": 316.52, "params_m": 0.972}},
)


@register("unet", capacity="two_stage")
def build_unet(*, budget: float, UN: bool = True, AS: bool = False, KP: bool = False, PP: bool = False,
               FG: bool = False, SA: bool = False, **two_stage: Any) -> nn.Module:
    """Row A of the two-stage model at ``budget``: :func:`mcd.models.two_stage.build_two_stage`'s settings
    and widths (``capacity.two_stage``) with only ``UN`` on; a switch other than UN turned on is an error
    (use ``two_stage`` then)."""
    on = [s for s, v in {"AS": AS, "KP": KP, "PP": PP, "FG": FG, "SA": SA}.items() if v]
    if on:
        raise ValueError(f"method.name=unet is component row A (only UN); it cannot take "
                         f"method.{on[0]}=true. Use method=two_stage (conf/method/) for other switch rows, "
                         "or +experiment=unet")
    kwargs = {"budget": budget, **ROW_A, **two_stage}
    check_call("two_stage", build_two_stage, kwargs)  # names a key the two-stage model does not take
    return build_two_stage(**kwargs)

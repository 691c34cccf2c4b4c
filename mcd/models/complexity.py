"""Params and MACs of a method (docs/benchmark.md "Metrics"), as a run records them (``metrics.json``
``params_m``, ``macs_g``) and ``python -m mcd.complexity`` tables them beside the paper's.

MACs = FLOPs / 2 of one forward pass producing one output frame, whole pipeline, counted by
``torch.utils.flop_counter.FlopCounterMode``. The count runs on the ``meta`` device (shapes only, no memory,
instant at 1080p); ``tests/models/test_complexity.py`` shows it equals the count of a real CPU forward.
"""

from __future__ import annotations

import torch
from torch import nn
from torch.utils import flop_counter

from mcd.data.synthetic import synthetic_frame


def _cpu_flash_attention_flop(query, key, value, *args, out_shape=None, **kwargs) -> int:
    """FLOPs of CPU flash attention, which ``FlopCounterMode`` does not count by itself (gets shapes)."""
    return flop_counter.sdpa_flop_count(query, key, value)


def flop_counter_mode() -> flop_counter.FlopCounterMode:
    """A ``FlopCounterMode`` that also counts CPU flash attention (so CPU, CUDA and meta counts agree)."""
    mapping = {torch.ops.aten._scaled_dot_product_flash_attention_for_cpu: _cpu_flash_attention_flop}
    return flop_counter.FlopCounterMode(display=False, custom_mapping=mapping)


def dummy_batch(model: nn.Module, height: int, width: int, device: torch.device | str,
                batch: int = 1) -> dict[str, torch.Tensor | None]:
    """Synthetic inputs for ``model.required_buffers()`` (:func:`mcd.data.synthetic.synthetic_frame`; ``ref``
    None, as at test time)."""
    past, future = getattr(model, "window", (0, 0))
    frames = past + 1 + future
    lead = (batch,) if frames == 1 else (batch, frames)
    return {"ref": None, **synthetic_frame(model.required_buffers(), height, width, lead, device=device)}


def count_params(model: nn.Module) -> int:
    """Trainable parameters; for a method that runs a network torch does not hold (OIDN), that network's
    (``model.network_params()``)."""
    if hasattr(model, "network_params"):
        return int(model.network_params())
    return sum(p.numel() for p in model.parameters() if p.requires_grad)


def count_macs(model: nn.Module, height: int = 1080, width: int = 1920, device: str = "meta") -> int:
    """MACs of one forward pass of ``model`` (on ``device``) producing one ``height x width`` frame."""
    model.eval()
    if hasattr(model, "reset"):
        model.reset()
    x = dummy_batch(model, height, width, device)
    with torch.no_grad(), flop_counter_mode() as counter:
        model(x)
    if hasattr(model, "reset"):
        model.reset()
    return counter.get_total_flops() // 2


def complexity(cfg, height: int = 1080, width: int = 1920, device: str = "meta") -> tuple[float, float]:
    """``(params in M, GMACs)`` of the method ``cfg`` describes, built on ``device``."""
    from mcd.models import build

    with torch.device(device):
        model = build(cfg)
    return count_params(model) / 1e6, count_macs(model, height, width, device) / 1e9

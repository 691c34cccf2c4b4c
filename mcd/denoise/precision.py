"""``mcd.denoise --precision``: the number format the network runs in (docs/denoise.md "Speed").

- ``fp32`` (default): full precision, contiguous tensors.
- ``bf16``: ``torch.autocast`` to bfloat16 with channels-last model and inputs, the bench's half path
  (docs/inference.md); on a CPU only where it computes bf16 natively (AVX512-BF16 or AMX), since emulated bf16
  is slower than fp32.
- ``fp16``: the same with float16, on a GPU only (CPU autocast has no fast fp16 path).

Outputs are written as fp32 EXR either way; half precision changes them by bf16/fp16 rounding.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # torch is imported where used, so that --help starts fast (docs/architecture.md)
    import torch
    from torch import nn

#: ``--precision`` choices and the name of their autocast dtype in torch (None: fp32, no autocast).
PRECISIONS: dict[str, str | None] = {"fp32": None, "bf16": "bfloat16", "fp16": "float16"}


def check(name: str, device: torch.device) -> torch.dtype | None:
    """The autocast dtype of ``--precision=name`` on ``device``; ValueError (what to use instead) where that
    precision has no fast path there."""
    import torch

    from mcd.lit.precision import cpu_bf16_supported

    if name not in PRECISIONS:
        raise ValueError(f"--precision={name}: use one of {', '.join(PRECISIONS)}")
    dtype = getattr(torch, PRECISIONS[name]) if PRECISIONS[name] else None
    if device.type == "cpu" and dtype is torch.float16:
        raise ValueError("--precision=fp16 runs on a GPU only; on the CPU use --precision bf16 (where the "
                         "CPU has native bf16) or fp32")
    if device.type == "cpu" and dtype is torch.bfloat16 and not cpu_bf16_supported():
        raise ValueError("--precision=bf16: this CPU has no native bf16 (AVX512-BF16 or AMX), where bf16 is "
                         "slower than fp32; use --precision fp32")
    if device.type == "cuda" and dtype is torch.bfloat16 and not torch.cuda.is_bf16_supported():
        raise ValueError(f"--precision=bf16: {device} has no bf16; use --precision fp16 or fp32")
    return dtype


def prepare(model: nn.Module, dtype: torch.dtype | None) -> nn.Module:
    """``model`` in the memory format of the precision: channels-last for the half precisions."""
    import torch

    return model if dtype is None else model.to(memory_format=torch.channels_last)


def layout(t: torch.Tensor, dtype: torch.dtype | None) -> torch.Tensor:
    """An input image in the memory format of the precision (a 4-D tensor channels-last for the half
    precisions; frame windows, 5-D, as they are)."""
    import torch

    return t.contiguous(memory_format=torch.channels_last) if dtype is not None and t.ndim == 4 else t


@contextlib.contextmanager
def running(device: torch.device, dtype: torch.dtype | None) -> Iterator[None]:
    """Inference mode (where the CPU fast paths apply, docs/inference.md) and autocast to ``dtype``."""
    import torch

    from mcd.lit.precision import autocast_to

    with torch.inference_mode(), autocast_to(device, dtype):
        yield

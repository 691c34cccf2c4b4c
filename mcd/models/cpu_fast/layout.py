"""The memory layout a fast path hands its result back in (docs/inference.md "Fast paths"): the kernel
application (:func:`mcd.models.kernel_pool.apply_pixel_kernels`) and the training paths' backward functions
(:mod:`mcd.models.cpu_fast.replicate`, :mod:`mcd.models.cpu_fast.upsample`) compute in the layout that is fast
and return the gradient or output in the one their input had."""

from __future__ import annotations

import torch
from torch import Tensor


def memory_format(x: Tensor) -> torch.memory_format:
    """``torch.channels_last`` for a 4-D tensor laid out so (and not also plain contiguous), else
    ``torch.contiguous_format``."""
    if x.dim() == 4 and x.is_contiguous(memory_format=torch.channels_last) and not x.is_contiguous():
        return torch.channels_last
    return torch.contiguous_format

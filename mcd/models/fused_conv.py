"""Convolutions with oneDNN post-ops for CPU inference (docs/inference.md, "Fused post-ops").

A 3x3 conv block of a U-Net (paper Sec. 4: every block of ``F_d``, and of ``F_s`` without FG) is a
convolution and a ReLU; a decoder block reads the concatenation of the upsampled features and the skip; a
Fast GhostConv block run on parts of its input sums one point-wise convolution per part. Run as separate
operations, the ReLU and the sum are one more pass over the output each and the concatenation a copy of both
inputs into a new full-resolution tensor. oneDNN applies them inside the convolution, as post-ops:

- :func:`conv2d`: a convolution, optionally added in place to an existing tensor (oneDNN's ``binary add``
  post-op) and followed by a ReLU, both applied as each output is written.
- :func:`conv_on_parts`: ``conv(cat(parts))`` (optionally followed by the ReLU) as one convolution per part
  with the columns of the weight that read it, each after the first adding into the first's output, the
  ReLU fused into the last. Same function, same MACs; the concatenation is never built.

Both call PyTorch's oneDNN fusion operators (``torch.ops.mkldnn._convolution_pointwise`` and its in-place
``binary`` form, the ones inductor's CPU backend emits for the same patterns). :func:`applies` says when:
CPU tensors under ``torch.inference_mode`` (no autograd: training keeps the plain operations), no CPU
autocast (whose casts these operators take no part in), inputs in the weight's dtype, and a PyTorch built
with oneDNN. Elsewhere the callers run the plain operations. Tested against them in
``tests/models/test_inference_paths.py``.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import Tensor, nn


def applies(weight: Tensor, parts: Sequence[Tensor]) -> bool:
    """Whether the fused operators may run a convolution of ``weight`` on ``parts`` (see the module
    docstring): CPU inference mode without autocast and inputs in the weight's dtype."""
    return (torch.is_inference_mode_enabled() and torch.backends.mkldnn.is_available()
            and not torch.is_autocast_enabled("cpu")
            and all(p.device.type == "cpu" and p.dtype == weight.dtype for p in parts))


def conv2d(x: Tensor, weight: Tensor, bias: Tensor | None, padding: Sequence[int] = (0, 0), groups: int = 1,
           relu: bool = False, add_to: Tensor | None = None) -> Tensor:
    """``F.conv2d(x, weight, bias, padding=padding, groups=groups)`` (stride 1, zero padding), added in place
    to ``add_to`` when given (returned), then ReLU if ``relu``; the add and the ReLU are post-ops of the
    convolution (call only where :func:`applies`)."""
    args = (list(padding), [1, 1], [1, 1], groups)
    mkldnn = torch.ops.mkldnn
    if add_to is None:
        return mkldnn._convolution_pointwise(x, weight, bias, *args, "relu" if relu else "none", [], "")
    return mkldnn._convolution_pointwise_.binary(add_to, x, weight, bias, *args, "add", 1.0,
                                                 "relu" if relu else None, [], "")


def conv_on_parts(conv: nn.Conv2d, parts: Sequence[Tensor], relu: bool) -> Tensor:
    """``conv(cat(parts, 1))``, then ReLU if ``relu``, without the concatenation: one convolution per part
    (a dense, stride-1, zero-padded ``conv``), the later ones adding into the first's output in place (call
    only where :func:`applies`)."""
    if conv.groups != 1 or conv.stride != (1, 1) or conv.dilation != (1, 1) or conv.padding_mode != "zeros":
        raise ValueError(f"conv_on_parts splits the input channels of a dense, stride-1, zero-padded conv; "
                         f"got {conv}")
    widths = [p.shape[1] for p in parts]
    if sum(widths) != conv.in_channels or not parts:
        raise ValueError(f"conv_on_parts: the parts have {widths} channels; the conv reads "
                         f"{conv.in_channels}")
    first = widths[0]
    out = conv2d(parts[0], conv.weight[:, :first], conv.bias, conv.padding, relu=relu and len(parts) == 1)
    start = first
    for k, (part, c) in enumerate(zip(parts[1:], widths[1:], strict=True), 2):
        conv2d(part, conv.weight[:, start : start + c], None, conv.padding, relu=relu and k == len(parts),
               add_to=out)
        start += c
    return out

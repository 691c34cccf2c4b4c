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
CPU tensors under ``torch.inference_mode`` (no autograd: training keeps the plain operations), a PyTorch
built with oneDNN, and fp32 or bf16 (where oneDNN computes bf16). Autocast does not see these operators, so
under CPU autocast :func:`conv2d` casts the operands to autocast's dtype itself, as autocast would for
``F.conv2d``. Elsewhere the callers run the plain operations. Tested against them in
``tests/models/test_inference_paths.py``.
"""

from __future__ import annotations

from collections.abc import Sequence

import torch
from torch import Tensor, nn


def compute_dtype(weight: Tensor) -> torch.dtype:
    """The dtype a convolution of ``weight`` computes in here: CPU autocast's where it is on (autocast runs
    convolutions in its lower precision), else the weight's."""
    return torch.get_autocast_dtype("cpu") if torch.is_autocast_enabled("cpu") else weight.dtype


def applies(weight: Tensor, parts: Sequence[Tensor]) -> bool:
    """Whether the fused operators may run a convolution of ``weight`` on ``parts`` (see the module
    docstring): CPU inference mode, fp32 or (where oneDNN computes it) bf16, and inputs in that dtype or,
    under autocast, in the weight's."""
    if not (torch.is_inference_mode_enabled() and torch.backends.mkldnn.is_available()):
        return False
    dtype = compute_dtype(weight)
    supported = dtype == torch.float32 or (dtype == torch.bfloat16
                                           and torch.ops.mkldnn._is_mkldnn_bf16_supported())
    return supported and all(p.device.type == "cpu" and p.dtype in (dtype, weight.dtype) for p in parts)


def conv2d(x: Tensor, weight: Tensor, bias: Tensor | None, padding: Sequence[int] = (0, 0), groups: int = 1,
           relu: bool = False, add_to: Tensor | None = None) -> Tensor:
    """``F.conv2d(x, weight, bias, padding=padding, groups=groups)`` (stride 1, zero padding), added in place
    to ``add_to`` when given (returned), then ReLU if ``relu``; the add and the ReLU are post-ops of the
    convolution. Under CPU autocast the operands are cast to its dtype first, as autocast casts a conv's (call
    only where :func:`applies`)."""
    dtype = compute_dtype(weight)
    x, weight = x.to(dtype), weight.to(dtype)
    bias = None if bias is None else bias.to(dtype)
    args = (list(padding), [1, 1], [1, 1], groups)
    mkldnn = torch.ops.mkldnn
    if add_to is None:
        return mkldnn._convolution_pointwise(x, weight, bias, *args, "relu" if relu else "none", [], "")
    # torch 2.13 sends a bf16 add + ReLU on NCHW tensors to an ATen kernel without bf16: ReLU separately there
    cl = add_to.is_contiguous(memory_format=torch.channels_last)
    split_relu = relu and dtype == torch.bfloat16 and not cl
    out = mkldnn._convolution_pointwise_.binary(add_to, x, weight, bias, *args, "add", 1.0,
                                                "relu" if relu and not split_relu else None, [], "")
    return out.relu_() if split_relu else out


def conv_on_parts(conv: nn.Conv2d, parts: Sequence[Tensor], relu: bool) -> Tensor:
    """``conv(cat(parts, 1))``, then ReLU if ``relu``, without the concatenation: one convolution per part
    (a dense, stride-1, zero-padded ``conv``), the later ones adding into the first's output in place (call
    only where :func:`applies`)."""
    if conv.groups != 1 or conv.stride != (1, 1) or conv.dilation != (1, 1) or conv.padding_mode != "zeros":
        raise ValueError(f"conv_on_parts splits the input channels of a dense, stride-1, zero-padded conv; "
                         f"got {conv}")
    widths = [p.shape[1] for p in parts]
    if sum(widths) != conv.in_channels:
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

"""Weight initialisation of the two-stage networks (``method.init``; docs/method.md "Initialisation").

- ``torch``: PyTorch's default for every convolution (weights uniform with a variance of ``1 / (3 fan_in)``,
  biases uniform in ``+-1 / sqrt(fan_in)``). In ``F_s``'s Fast GhostConv blocks (three convolutions, one
  ReLU) at small widths it shrinks the spatial signal about tenfold per block: at initialisation row F's
  sampling logits at ``capacity=cpu`` vary by about 1e-6 over a frame, so the map starts uniform and the
  gradient reaching ``F_s``'s first blocks is as small; a block whose units all turn negative stays dead,
  since no gradient passes it (F-cpu-bundle's ``F_s`` outputs one constant: docs/method.md "Initialisation").
- ``he``: normal weights of variance ``gain^2 / fan_in`` (``fan_in`` counting a grouped convolution's own
  inputs) and zero biases, with He et al.'s ``gain = sqrt(2)`` for a convolution whose output goes through a
  ReLU (a :class:`~mcd.models.blocks.ConvReLU`'s, a Fast GhostConv's pointwise and ghost convolutions) and
  ``gain = 1`` for the others (a Fast GhostConv's group convolution, which feeds the pointwise one directly;
  output heads). Measured at initialisation (row F, ``capacity=cpu``, 64x64 inputs): ``F_s``'s blocks keep a
  spatial standard deviation of 0.05-0.2 from the first to the last (``torch``: 2.6e-2 down to 1e-8) and the
  logits vary by about 0.1 (a gently non-uniform map).

The paper states neither. Only convolutions are initialised here (the kernel pool's kernels and the
attention's projections keep their own).
"""

from __future__ import annotations

import math

from torch import nn

from mcd.models.blocks import ConvReLU
from mcd.models.ghost_conv import FastGhostConv

#: ``method.init``'s values.
INITS = ("torch", "he")


def initialise(module: nn.Module, init: str) -> None:
    """Initialise every ``nn.Conv2d`` of ``module`` by ``init`` (:data:`INITS`; the module docstring);
    ``torch`` leaves them as built. ``ValueError`` naming ``method.init`` for another value."""
    if init not in INITS:
        raise ValueError(f"method.init={init!r}: use one of {', '.join(INITS)}")
    if init == "torch":
        return
    into_relu: set[int] = set()
    for block in module.modules():
        if isinstance(block, FastGhostConv):
            into_relu |= {id(block.point), id(block.ghost)}
        elif isinstance(block, ConvReLU):
            into_relu.add(id(block.conv))
    for conv in module.modules():
        if isinstance(conv, nn.Conv2d):
            gain = math.sqrt(2.0) if id(conv) in into_relu else 1.0
            fan_in = conv.in_channels // conv.groups * math.prod(conv.kernel_size)
            nn.init.normal_(conv.weight, 0.0, gain / math.sqrt(fan_in))
            if conv.bias is not None:
                nn.init.zeros_(conv.bias)

"""``method.init`` (mcd/models/init.py; docs/method.md "Initialisation"): PyTorch's default leaves row F's
sampling network nearly constant at initialisation, He's keeps its signal; the values are checked by name."""

from __future__ import annotations

import math

import pytest
import torch
from torch import nn

from mcd.models.init import initialise
from mcd.models.registry import build
from tests.conftest import compose_cfg


def _row_f(init: str) -> nn.Module:
    torch.manual_seed(0)
    return build(compose_cfg("+experiment=F", "capacity=cpu", f"method.init={init}"))


def _sampler_logits(model: nn.Module) -> torch.Tensor:
    x = torch.rand(2, 12, 64, 64, generator=torch.Generator().manual_seed(1))
    x[:, 3:6] = 2 * x[:, 3:6] - 1  # normals
    with torch.no_grad():
        return model.sampler(x)["logits"]


def test_torch_init_is_the_build_as_it_was():
    built, torch_init = _row_f("torch"), _row_f("torch")
    initialise(torch_init, "torch")
    for (name, a), b in zip(built.state_dict().items(), torch_init.state_dict().values(), strict=True):
        assert torch.equal(a, b), name


def test_he_init_zero_biases_and_the_stated_variance():
    from mcd.models.blocks import ConvReLU
    from mcd.models.ghost_conv import FastGhostConv

    model = _row_f("he")
    convs = [m for m in model.modules() if isinstance(m, nn.Conv2d)]
    assert convs and all(c.bias is None or not c.bias.any() for c in convs)
    into_relu = max((m.conv for m in model.modules() if isinstance(m, ConvReLU)),
                    key=lambda c: c.weight.numel())
    group = max((m.group for m in model.modules() if isinstance(m, FastGhostConv)),
                key=lambda c: c.weight.numel())
    for conv, gain in ((into_relu, math.sqrt(2)), (group, 1.0)):
        assert conv.weight.numel() > 1000
        fan_in = conv.in_channels // conv.groups * math.prod(conv.kernel_size)
        assert float(conv.weight.std()) == pytest.approx(gain / math.sqrt(fan_in), rel=0.1)


def test_he_keeps_the_sampling_networks_signal_where_torch_loses_it():
    # PyTorch's default shrinks F_s's signal about tenfold per Fast GhostConv block: a uniform map to start
    # from, and a vanishing gradient into the first blocks (the module docstring's figures)
    assert float(_sampler_logits(_row_f("torch")).std()) < 1e-4
    he = float(_sampler_logits(_row_f("he")).std())
    assert 1e-2 < he < 1.0  # a gently non-uniform map: softmax far from one-hot


def test_an_unknown_init_is_refused_by_name():
    with pytest.raises(ValueError, match="method.init='xavier'"):
        _row_f("xavier")

"""``tools/sampler_signal.py`` (docs/method.md "Initialisation"): it finds F-cpu-bundle's sampling network
constant from its first level's second block on, and a freshly built F with He's initialisation alive."""

from __future__ import annotations

import torch

from tools.sampler_signal import block_table


def test_the_bundle_with_a_dead_block_and_a_live_fresh_build():
    from mcd.config.compose import compose
    from mcd.denoise import weights
    from mcd.models.registry import build

    rows, logits = block_table(weights.load("F-cpu-bundle").model, 32, 0)
    stds = dict((name, std) for name, std, _ in rows)
    assert stds["encoder.0.0"] > 1e-3 and stds["encoder.0.1"] == 0.0
    assert all(std < 1e-6 for name, std in stds.items() if name != "encoder.0.0") and logits < 1e-6

    torch.manual_seed(0)
    rows, logits = block_table(build(compose(["+experiment=F", "capacity=cpu", "method.init=he"])), 32, 0)
    assert all(std > 1e-2 for _, std, _ in rows) and logits > 1e-2

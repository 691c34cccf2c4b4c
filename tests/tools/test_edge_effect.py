"""The edge effect (tools/edge_effect.py; docs/benchmark.md "Metrics"): what the image border itself costs
a denoiser, measured on real 32x32 Cornell-box renders."""

from __future__ import annotations

import pytest
import torch
from torch import nn

from mcd.data.buffers import run_buffers
from mcd.data.datamodule import MCDDataModule
from mcd.lit.module import DenoiseModule
from mcd.models import build
from tests.conftest import compose_cfg, store32_overrides
from tools.edge_effect import inset_batch, measure


class DarkBorder(nn.Module):
    """A real method (the noisy input) whose output loses half its value on the outer 4-pixel frame: the
    kind of border artefact the edge effect must find."""

    def __init__(self, inner: nn.Module) -> None:
        super().__init__()
        self.inner = inner
        self.window = inner.window

    def reset(self) -> None:
        self.inner.reset()

    def forward(self, x: dict[str, torch.Tensor | None]) -> dict[str, torch.Tensor]:
        out = dict(self.inner(x))
        y = out["output"].clone()
        y[..., :4, :] *= 0.5
        y[..., -4:, :] *= 0.5
        y[..., :, :4] *= 0.5
        y[..., :, -4:] *= 0.5
        out["output"] = y
        return out


def test_the_input_has_no_edge_effect_and_a_dark_border_has_one(cbox_store):
    store = cbox_store[1]
    cfg = compose_cfg(*store32_overrides(store.data_dir), "+experiment=noisy")
    noisy = build(cfg).eval()
    datamodule = MCDDataModule(cfg, store, run_buffers(noisy.required_buffers(), cfg.budget), noisy.window)
    datamodule.setup("test")
    batches = list(datamodule.test_dataloader())
    rows = measure(DenoiseModule(cfg, noisy, None), batches, margin=8)
    assert len(rows) == len(batches) >= 2
    assert all(r["edge_effect"] == 0.0 for r in rows)  # the same pixels, the same values
    rows = measure(DenoiseModule(cfg, DarkBorder(noisy), None), batches, margin=8)
    assert all(r["edge_effect"] < -3.0 for r in rows), [r["edge_effect"] for r in rows]


class AutocastProbe(nn.Module):
    """The noisy input, recording whether each call ran under CPU bf16 autocast."""

    def __init__(self, inner: nn.Module) -> None:
        super().__init__()
        self.inner, self.window, self.seen = inner, inner.window, []

    def reset(self) -> None:
        self.inner.reset()

    def forward(self, x: dict[str, torch.Tensor | None]) -> dict[str, torch.Tensor]:
        bf16 = torch.get_autocast_dtype("cpu") == torch.bfloat16
        self.seen.append(torch.is_autocast_enabled("cpu") and bf16)
        return self.inner(x)


def test_measure_runs_under_the_precision_the_run_tested_with(cbox_store):
    """A bf16-mixed run tested under bf16 autocast: an adaptive model's integer map rounds from its logits, so
    its frames are re-scored the same way (fp32 and bf16 logits can draw different samples)."""
    store = cbox_store[1]
    cfg = compose_cfg(*store32_overrides(store.data_dir), "+experiment=noisy")
    noisy = build(cfg).eval()
    datamodule = MCDDataModule(cfg, store, run_buffers(noisy.required_buffers(), cfg.budget), noisy.window)
    datamodule.setup("test")
    batches = list(datamodule.test_dataloader())[:1]
    for precision, expected in (("bf16-mixed", True), ("32-true", False)):
        probe = AutocastProbe(noisy)
        measure(DenoiseModule(cfg, probe, None), batches, margin=8, precision=precision)
        assert probe.seen == [expected, expected]  # the whole frame, then its crop


def test_inset_batch_cuts_every_image_buffer_and_refuses_too_small_frames():
    batch = {"c4": torch.zeros(1, 2, 3, 40, 30), "scene": ["cbox"], "frame": torch.zeros(1, 2)}
    cut = inset_batch(batch, 8)
    assert cut["c4"].shape == (1, 2, 3, 24, 14) and cut["scene"] == ["cbox"] and cut["frame"].shape == (1, 2)
    with pytest.raises(ValueError, match="too small"):
        inset_batch(batch, 10)  # 30 - 20 leaves no interior inside a 4-pixel frame


def test_map_border_reads_the_outermost_ring_of_the_maps():
    from tools.edge_effect import map_border

    m = torch.full((1, 1, 40, 30), 2.0)
    m[..., 0, :] = m[..., -1, :] = m[..., :, 0] = m[..., :, -1] = 6.0
    k = torch.zeros(1, 2, 40, 30)
    k[:, 0, 0, :] = k[:, 0, -1, :] = k[:, 0, :, 0] = k[:, 0, :, -1] = 1.0
    got = map_border({"output": torch.zeros(1, 3, 40, 30), "sampling_map": m, "kernel_map": k})
    assert got == {"map_border_ratio": 3.0, "index_border": 1.0, "index_interior": 0.0}
    assert map_border({"output": torch.zeros(1, 3, 40, 30)}) == {}

"""``trainer.precision`` is checked before anything is rendered, and a run records the precision it trained in
(docs/reliability.md, "Campaign fixes"; mcd/lit/precision.py): ``trainer.precision=banana`` failed in
Lightning after the store was rendered, ``64-true`` failed at the first step ("Input type (float) and bias
type (double) should be the same"), and ``16-mixed`` on the CPU trained in bf16-mixed (Lightning's own switch)
while ``metrics.json`` said ``16-mixed``."""

from __future__ import annotations

import json

import pytest

from tests.conftest import mcd_run, store32_overrides

RUN = ["+experiment=unet", "train.max_steps=2", "train.batch_size=1", "train.sample_frames=[]",
       "trainer.enable_progress_bar=false", "trainer.accelerator=cpu"]


@pytest.mark.parametrize("value", ["banana", "64-true"])
@pytest.mark.slow
def test_an_unusable_precision_is_named_before_anything_is_rendered(tmp_path, value):
    data = tmp_path / "data"
    proc = mcd_run(*RUN, *store32_overrides(data), f"trainer.precision={value}",
                   f"hydra.run.dir={tmp_path / 'run'}")
    assert proc.returncode != 0
    assert f"trainer.precision={value}: give one of auto, 32-true" in proc.stderr, proc.stderr[-3000:]
    assert not list(data.rglob("*.exr"))  # nothing rendered


@pytest.mark.slow
def test_fp16_mixed_on_the_cpu_is_recorded_as_the_bf16_it_trains_in(cbox_store, tmp_path):
    run = tmp_path / "run"
    proc = mcd_run(*RUN, *store32_overrides(cbox_store[1].data_dir), "trainer.precision=16-mixed",
                   f"hydra.run.dir={run}")
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert json.loads((run / "metrics.json").read_text())["precision"] == "bf16-mixed"
    assert "trainer.precision=16-mixed -> bf16-mixed" in proc.stdout + proc.stderr


@pytest.mark.slow
@pytest.mark.parametrize("value", ["bf16-true", "16-true"])
def test_half_precision_weights_are_named_before_anything_is_rendered(tmp_path, value):
    """Campaign 10, part 1: ``bf16-true`` and ``16-true`` were accepted, the store was rendered, and the first
    training step failed ("Input type (float) and bias type (c10::BFloat16) should be the same")."""
    data = tmp_path / "data"
    proc = mcd_run(*RUN, *store32_overrides(data), f"trainer.precision={value}",
                   f"hydra.run.dir={tmp_path / 'run'}")
    assert proc.returncode != 0
    assert f"trainer.precision={value}: half-precision weights are not supported" in proc.stderr, \
        proc.stderr[-3000:]
    assert not list(data.rglob("*.exr"))  # nothing rendered

"""The LightningModule on real renders: one training step per component row A-M, NaN handling, test phase."""

import json
import logging
import math

import lightning as L
import numpy as np
import pandas as pd
import pytest
import torch

from mcd.data import MCDDataModule, StoreBuilder
from mcd.data.exr import sha256, write_exr
from mcd.lit import DenoiseModule
from mcd.lit.test_recorder import TestRecorder
from mcd.losses import build_loss
from mcd.models import build

from .conftest import compose_cfg

ROWS = "ABCDEFGHIJKLM"


def parts(data_dir, *overrides):
    cfg = compose_cfg(data_dir, *overrides)
    model = build(cfg)
    buffers = set(model.required_buffers()) | {"ref", f"c{cfg.budget}"}
    store = StoreBuilder.from_cfg(cfg)
    dm = MCDDataModule(cfg, store, buffers, model.window)
    return cfg, DenoiseModule(cfg, model, build_loss(cfg)), dm


def trainer(**kw):
    return L.Trainer(accelerator="cpu", logger=False, enable_checkpointing=False, enable_progress_bar=False,
                     enable_model_summary=False, num_sanity_val_steps=0, **kw)


@pytest.mark.parametrize("row", ROWS)
def test_each_component_row_runs_one_training_step(tiny_store, row):
    torch.manual_seed(0)
    cfg, lit, dm = parts(tiny_store, f"+experiment={row}")
    before = [p.detach().clone() for p in lit.model.parameters()]
    t = trainer(max_steps=1, limit_val_batches=0)
    t.fit(lit, datamodule=dm)
    assert t.global_step == 1
    loss = t.callback_metrics["train/loss"]
    assert torch.isfinite(loss) and loss > 0
    changed = sum(not torch.equal(a, b) for a, b in zip(before, lit.model.parameters(), strict=True))
    assert changed > 0, f"row {row}: no parameter moved in one Adam step"


def test_test_phase_carries_state_and_writes_metrics_and_samples(tiny_store, tmp_path):
    cfg, lit, dm = parts(tiny_store, "+experiment=F", "train.sample_frames=[1]")
    recorder = TestRecorder(tmp_path, cfg.train.sample_frames)
    resets = []
    reset = lit.model.reset
    lit.model.reset = lambda: (resets.append(True), reset())[1]
    trainer(callbacks=[recorder]).test(lit, datamodule=dm, verbose=False)
    rows = recorder.rows
    assert [r["frame"] for r in rows] == [0, 1] and {r["scene"] for r in rows} == {"cbox"}
    assert len(resets) == 1  # once at the sequence start, not per frame
    assert math.isnan(rows[0]["lt"]) and rows[1]["lt"] >= 0
    for r in rows:
        assert 0 <= r["ssim"] <= 1 and r["input_psnr"] > 5 and r["rmse"] >= 0
        assert 0 <= r["kp_identity"] <= 1  # F has KP: its kernel map's identity share is recorded
    names = {p.name for p in (tmp_path / "samples" / "cbox").iterdir()}
    for what in ("output", "reference", "noisy", "sampling_map", "kernel_map", "initial", "adaptive"):
        assert {f"0001_{what}.exr", f"0001_{what}.png"} <= names, what
    assert not any(n.startswith("0000_") for n in names)
    frames = pd.read_csv(tmp_path / "frames.csv")  # the recorder's rows, and their averages
    assert frames["frame"].tolist() == [0, 1] and "kp_index_std" in frames.columns
    assert recorder.averages["frames"] == {"cbox": 2}
    assert recorder.averages["psnr"] == pytest.approx(frames["psnr"].mean())


def test_nan_in_a_rendered_frame_is_sanitised_and_never_reaches_the_loss(tiny_store, tmp_path, caplog):
    # Copy the store and put NaN/Inf into one training frame's input, as a renderer fault would (the manifest
    # records the file as written, so only the loader's sanitising stands between it and the loss).
    import shutil

    data = tmp_path / "data"
    shutil.copytree(tiny_store, data)
    cfg = compose_cfg(data, "+experiment=A")
    store = StoreBuilder.from_cfg(cfg)
    frame = store.frame_count("cbox") - 1  # the last frame is in the training clip
    path = store.path("cbox", frame, "c4")
    img = store.load("cbox", frame, "c4")
    img[3, 4] = np.nan
    img[5, 6, 1] = np.inf
    write_exr(path, img)
    man_path = store.manifest_path("cbox")
    man = json.loads(man_path.read_text())
    rec = man["files"][f"{frame:04d}/c4.exr"]
    rec.update(bytes=path.stat().st_size, sha256=sha256(path), nan=3, inf=1)
    man_path.write_text(json.dumps(man))

    _, lit, dm = parts(data, "+experiment=A")
    seen = []
    forward = lit.loss_fn.forward

    def spy(pred, ref):
        seen.append(bool(torch.isfinite(pred).all()))
        return forward(pred, ref)

    lit.loss_fn.forward = spy
    with caplog.at_level(logging.WARNING):
        t = trainer(max_steps=1, limit_val_batches=0)
        t.fit(lit, datamodule=dm)
    assert "c4.exr" in caplog.text and "replaced by 0" in caplog.text
    assert seen == [True] and torch.isfinite(t.callback_metrics["train/loss"])


def test_non_finite_input_that_bypasses_the_loader_is_refused(tiny_store):
    _, lit, dm = parts(tiny_store, "+experiment=A")
    dm.setup()
    batch = next(iter(dm.train_dataloader()))
    batch["c4"][0, 0, 0, 0, 0] = float("nan")
    with pytest.raises(ValueError, match="non-finite values in buffer 'c4'"):
        lit.run_clip(batch, with_ref=True)


def test_kernel_map_identity_share():
    from mcd.lit.test_recorder import kernel_map_identity_share

    h = torch.zeros(2, 2, 4, 4)
    h[:, 1] = 1.0
    assert kernel_map_identity_share(h) == 1.0  # every pixel takes the identity kernel
    h[:, 1] = -1.0
    assert kernel_map_identity_share(h) == 0.0  # every pixel takes its pool kernel
    h[:, 1, :2] = 1.0
    assert kernel_map_identity_share(h) == pytest.approx(0.5)



@pytest.mark.slow
def test_learning_rate_warms_up_linearly_then_follows_the_cosine(tiny_store, tmp_path):
    """``train.warmup_steps`` (mcd/lit/module.py, docs/training.md "Budgets"): the logged learning rate of a
    real 8-step run rises linearly over the first 4 steps, then follows the cosine of the budget."""
    import time

    from mcd.lit.module import cosine_factor, warmup_factor
    from mcd.run import train_and_test

    lr, lr_min, steps, warmup = 1e-3, 1e-5, 8, 4
    cfg = compose_cfg(tiny_store, "+experiment=A", f"train.max_steps={steps}",
                      "train.max_minutes=null", f"train.lr={lr}", f"train.lr_min={lr_min}",
                      f"train.warmup_steps={warmup}", "train.val_every_steps=1", "train.sample_frames=[]",
                      "trainer.enable_progress_bar=false")
    train_and_test(cfg, tmp_path, {}, time.perf_counter())
    logged = pd.read_csv(tmp_path / "curve.csv").set_index("step")["lr"]
    expected = {k: lr * warmup_factor(k, warmup) * cosine_factor(k / steps, lr, lr_min) for k in range(steps)}
    # the curve's lr at step n is the rate the optimiser holds after n steps: that of step n (0-based)
    for n in range(1, steps):
        assert logged[n] == pytest.approx(expected[n], rel=1e-6), n
    assert logged[1] < logged[2] < logged[3]
    assert logged[3] == pytest.approx(lr * cosine_factor(3 / steps, lr, lr_min))  # warm from step 3 on
    assert warmup_factor(0, 0) == 1.0 and warmup_factor(99, 100) == 1.0 and warmup_factor(0, 100) == 0.01


def test_a_bad_warmup_is_named_before_anything_runs(tiny_store):
    from mcd.config.preflight import check_run

    for bad in ("-1", "2.5", "true"):
        with pytest.raises(ValueError, match=r"train\.warmup_steps="):
            check_run(compose_cfg(tiny_store, f"train.warmup_steps={bad}"))


def test_the_gradient_norm_is_logged_each_step_before_clipping(tiny_store, tmp_path):
    """``train/grad_norm`` (mcd/lit/module.py): one finite, positive value per optimiser step in
    ``logs/metrics.csv``, read before ``train.grad_clip`` clips: with a clip far below it, the logged norm
    stays far above the clip."""
    import time

    from mcd.run import train_and_test

    steps, clip = 4, 1e-6
    cfg = compose_cfg(tiny_store, "+experiment=A", f"train.max_steps={steps}", "train.max_minutes=null",
                      f"train.grad_clip={clip}", "train.val_every_steps=2", "train.sample_frames=[]",
                      "trainer.log_every_n_steps=1", "trainer.enable_progress_bar=false")
    train_and_test(cfg, tmp_path, {}, time.perf_counter())
    (metrics,) = tmp_path.glob("**/metrics.csv")
    norms = pd.read_csv(metrics).dropna(subset=["train/grad_norm"]).set_index("step")["train/grad_norm"]
    assert sorted(norms.index) == list(range(steps))
    assert (norms > 1e3 * clip).all() and norms.map(math.isfinite).all()


def test_check_finite_refuses_exactly_what_isfinite_refuses():
    """The clip check (one max reduction) against ``torch.isfinite(...).all()``, buffer by buffer: NaN, +-Inf
    anywhere (first, last, inside a strided view), the largest finite values, all-black and empty buffers."""
    from mcd.lit.module import check_finite

    torch.manual_seed(0)
    cases = []
    for bad in (float("nan"), float("inf"), -float("inf"), 3.4e38, -3.4e38, 1e5, 0.0):
        for where in ((0, 0, 0, 0, 0), (3, 4, 2, 95, 95), (1, 2, 1, 50, 7)):
            clip = torch.rand(4, 5, 3, 96, 96)
            clip[where] = bad
            cases += [clip, clip[:, 1:, :, ::2]]
    cases += [torch.zeros(4, 5, 3, 96, 96), torch.zeros(0, 5, 3, 8, 8),
              torch.full((1, 1, 1, 3, 5), float("nan"))]
    for clip in cases:
        finite = bool(torch.isfinite(clip).all())
        if finite:
            check_finite({"c4": clip}, {})
        else:
            with pytest.raises(ValueError, match="non-finite values in buffer 'c4'"):
                check_finite({"c4": clip}, {})

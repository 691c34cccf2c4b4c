"""``trainer=ddp`` with two CPU processes (gloo): every test frame is tested once, by rank 0; both ranks agree
on one best checkpoint (validation metrics averaged over them); one ``metrics.json`` whose metrics equal a
single-process test of that checkpoint; the logged training loss is the mean over the ranks."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
import torch
import torch.distributed as dist
import torch.multiprocessing as mp

from mcd.core.metrics import FRAME_METRICS
from mcd.lit.module import mean_over_processes
from mcd.lit.run_record import RunRecord
from mcd.run import build, run_test
from tests.conftest import compose_cfg, store32_overrides

REPO = Path(__file__).resolve().parents[2]
#: Row A on a copy of the shared 32x32 store (12 frames; a copy, since 6 test frames re-render the references
#: of frames 2-5 at the test frames' quality): 6 test frames, two validation clips (one per rank, so ranks
#: that did not average their validation metrics would see different scores), one training clip; three
#: epochs of one step, each validated; fp32, so that the one-process test repeats the numbers to 1e-6 (bf16
#: autocast, the default on a CPU with native bf16, differs in the sixth digit with the summation order).
SPLIT = ["+experiment=A", "trainer.precision=32-true", "data.test_fraction=0.5", "data.clip_len=2",
         "data.val_clips=2", "train.batch_size=1", "train.epochs=3", "train.max_steps=null",
         "train.max_minutes=null", "train.val_every=1", "train.val_every_steps=null",
         "train.sample_frames=[]", "trainer.enable_progress_bar=false"]
DDP = ["trainer=ddp", "trainer.devices=2", "trainer.accelerator=cpu"]


@pytest.mark.slow
def test_two_process_ddp_tests_every_frame_once_on_one_best_checkpoint(own_store, tmp_path):
    overrides = [*store32_overrides(own_store[1].data_dir), *SPLIT]
    run = tmp_path / "ddp"
    env = {**os.environ, "OMP_NUM_THREADS": "1", "HYDRA_FULL_ERROR": "1"}
    proc = subprocess.run([sys.executable, "-m", "mcd.run", *overrides, *DDP, f"hydra.run.dir={run}"],
                          cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log[-4000:]
    assert "Starting with 2 processes" in log and "distributed_backend=gloo" in log

    # both ranks test the same best checkpoint, the only one kept
    picked = re.findall(r"testing checkpoint (\S+) \(best val/psnr (\S+) dB\)", log)
    assert len(picked) == 2 and picked[0] == picked[1], picked
    metrics = json.loads((run / "metrics.json").read_text())
    assert [p.name for p in (run / "checkpoints").glob("best-*.ckpt")] == [Path(picked[0][0]).name]
    assert metrics["checkpoint"] == picked[0][0] and metrics["best_val_psnr"] == pytest.approx(
        float(picked[0][1]), abs=0.01)
    assert metrics["train_steps"] == 3

    # every test frame once, and one metrics.json (one rank writes it, and logs its summary)
    frames = pd.read_csv(run / "frames.csv")
    assert list(zip(frames["scene"], frames["frame"], strict=True)) == [("cbox", f) for f in range(6)]
    assert metrics["test_frames"] == {"cbox": 6}
    assert len(re.findall(r"\] - A: PSNR ", log)) == 1

    # the same checkpoint tested in this (single) process gives the same frames and metrics, up to summation
    # order (measured: within 3e-9; the trained run tests in channels-last weights, train.channels_last)
    job = build(compose_cfg(*overrides), tmp_path / "single")
    run_test(job, metrics["checkpoint"])
    single = pd.DataFrame(job.recorder.rows, columns=["scene", "frame", *FRAME_METRICS])
    # within 1e-6, relative or absolute: colour_shift, |ratio - 1|, turns float rounding of a ~1.05 ratio into
    # a relative difference of ~2e-6 of its small value; border_gap, a difference of two PSNRs near 30 dB, to
    # 1e-5 dB (F_d's reflected margin runs a larger frame, whose sums round differently: 2.6e-6 dB measured)
    gaps = ["border_gap", "input_border_gap"]
    pd.testing.assert_frame_equal(frames.drop(columns=gaps), single.drop(columns=gaps), check_exact=False,
                                  rtol=1e-6, atol=1e-6)
    pd.testing.assert_frame_equal(frames[gaps], single[gaps], check_exact=False, rtol=0, atol=1e-5)
    expected = RunRecord.scores_of(job.recorder.averages)  # kp_* are None: row A has no kernel map
    assert {k for k, v in expected.items() if v is None} == {k for k in expected if metrics[k] is None}
    known = {k: v for k, v in expected.items() if v is not None}
    scene = job.recorder.averages["per_scene"]["cbox"]
    for got, want in ((metrics, known), (metrics["per_scene"]["cbox"], scene)):
        assert {k: got[k] for k in want if k not in gaps} == pytest.approx(
            {k: v for k, v in want.items() if k not in gaps}, rel=1e-6)
        assert {k: got[k] for k in want if k in gaps} == pytest.approx(
            {k: v for k, v in want.items() if k in gaps}, abs=1e-5)


def _rank_mean(rank: int, world: int, store: str, out: str) -> None:
    dist.init_process_group("gloo", init_method=f"file://{store}", rank=rank, world_size=world)
    try:
        terms = torch.tensor([1.0 + rank, 10.0 * rank, -rank])  # each rank's own loss terms
        torch.save(mean_over_processes(terms), f"{out}.{rank}")
    finally:
        dist.destroy_process_group()


def test_training_loss_is_logged_as_the_mean_over_ranks(tmp_path):
    """``DenoiseModule`` logs ``train/*`` through :func:`mean_over_processes`: two gloo processes with
    different terms both get their mean; outside a process group the terms come back as they are."""
    out = str(tmp_path / "mean")
    mp.start_processes(_rank_mean, args=(2, str(tmp_path / "store"), out), nprocs=2, start_method="fork")
    for rank in range(2):
        assert torch.equal(torch.load(f"{out}.{rank}", weights_only=True), torch.tensor([1.5, 5.0, -0.5]))
    one = torch.tensor([0.25, 3.0])
    assert mean_over_processes(one) is one

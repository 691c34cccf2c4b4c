"""A training run says where it stands and, at the end, what happened. A real tiny
run whose output is not a terminal logs plain progress lines (no carriage return at all) and ends with the
summary: why training stopped, steps and time, the test scores beside the noisy input's, per scene, the run
directory and the checkpoint (mcd/lit/progress.py, mcd/lit/run_summary.py)."""

from __future__ import annotations

import io
import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from mcd.lit.progress import ProgressLine
from tests.conftest import store32_overrides
from tests.reliability.conftest import FROZEN

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_a_non_tty_training_log_has_no_carriage_return_and_ends_with_the_summary(cbox_store, tmp_path):
    run = tmp_path / "run"
    overrides = [*store32_overrides(cbox_store[1].data_dir),
                 *(o for o in FROZEN if not o.startswith("trainer.enable_progress_bar")), "train.epochs=2"]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO)}
    proc = subprocess.run([sys.executable, "-m", "mcd.run", *overrides, f"hydra.run.dir={run}"], cwd=REPO,
                          env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, timeout=600)
    log = proc.stdout.decode()
    assert proc.returncode == 0, log[-4000:]
    assert b"\r" not in proc.stdout
    progress = re.findall(r"train: step (\d+)/2 \(\d+%\) \| epoch \d+ .*\| val PSNR [\d.]+ dB", log)
    assert progress and progress[-1] == "2"  # a line at each validation, the last at the budget
    m = json.loads((run / "metrics.json").read_text())
    lines = log.rstrip("\n").splitlines()
    start = max(i for i, line in enumerate(lines) if "run summary of A (budget 4 spp, seed 0)" in line)
    summary = lines[start:]
    assert summary[1].startswith("  training stopped by the epoch budget (train.epochs=2) after 2 steps, "
                                 "2 epochs, ")
    scores = {line.split()[0]: line.split()[-2:] for line in summary[4:8]}
    assert scores["PSNR"] == [f"{m['psnr']:.2f}", f"{m['input_psnr']:.2f}"]
    assert scores["SSIM"] == [f"{m['ssim']:.4f}", f"{m['input_ssim']:.4f}"]
    assert scores["FLIP"] == [f"{m['flip']:.4f}", f"{m['input_flip']:.4f}"] and "rMSE" in scores
    assert summary[9].startswith(f"    cbox: {m['per_scene']['cbox']['psnr']:.2f} "
                                 f"({m['per_scene']['cbox']['input_psnr']:.2f})")
    assert summary[-2:] == [f"  run directory: {run}", f"  checkpoint tested: {m['checkpoint']}"]


class _Trainer:
    """What :class:`ProgressLine` reads of a trainer, for the line's arithmetic."""

    def __init__(self, step: int) -> None:
        self.global_step, self.current_epoch, self.num_training_batches = step, 0, 100
        self.callbacks: list = []
        self.callback_metrics = {"train/loss_step": 0.25}
        self.is_global_zero, self.sanity_checking = True, False


def test_the_line_gives_step_against_budget_loss_last_val_psnr_and_eta():
    out = io.StringIO()
    train = OmegaConf.create({"max_steps": 1500, "epochs": None, "max_minutes": None})
    bar = ProgressLine(train, out, tty=False)
    trainer = _Trainer(0)
    bar.on_train_start(trainer, None)
    bar._t0 -= 50.0  # 50 s for the 100 steps below
    trainer.global_step = 100
    trainer.callback_metrics["val/psnr"] = 24.5
    bar.on_validation_end(trainer, None)
    line = out.getvalue()
    assert line.endswith("\n") and "\r" not in line
    assert line.startswith("train: step 100/1500 (7%) | epoch 0 | loss 0.25 | val PSNR 24.50 dB (step 100) "
                           "| ")
    assert re.search(r"\| 0.50 s/step \| ETA 11.7 min\n$", line), line  # 1400 steps left at 0.5 s
    bar.on_train_batch_end(trainer, None, None, None, 0)
    assert out.getvalue() == line  # not again before LOG_EVERY_S

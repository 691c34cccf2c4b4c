"""Each baseline trains (or, for ``noisy`` and ``oidn``, skips training) and tests end to end through
``python -m mcd.run +experiment=<name>`` on real renders (the vendored Cornell box at 32x32), writing the same
``metrics.json`` keys as the two-stage model (architecture.md "Run directory")."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
METHODS = ["unet", "rae", "fastdvdnet", "dasr", "ntasad", "noisy", "oidn"]
HAS_PYOIDN = importlib.util.find_spec("pyoidn") is not None
#: architecture.md, "Run directory": the keys every run's metrics.json holds.
KEYS = {"psnr", "ssim", "rmse", "lt", "input_psnr", "input_ssim", "input_rmse", "macs_g", "params_m",
        "experiment", "method", "budget", "data_profile", "commit", "device", "wall_s", "per_scene",
        "perceptual_loss"}


@pytest.mark.slow
def test_every_baseline_runs_end_to_end(tmp_path: Path) -> None:
    methods = METHODS if HAS_PYOIDN else METHODS[:-1]
    cmd = [sys.executable, "-m", "mcd.run", "-m", f"+experiment={','.join(methods)}",
           f"paths.data_dir={tmp_path / 'data'}", f"hydra.sweep.dir={tmp_path / 'runs'}",
           "hydra.sweep.subdir=${experiment}",
           "data.width=32", "data.height=32", "data.train_crop=32", "data.val_crop=32",
           "data.frames_per_segment=8", "data.ref_spp=64", "data.train_scenes=[cbox]",
           "data.test_scenes=[cbox]",
           "train.epochs=2"]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO)}
    res = subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    assert res.returncode == 0, res.stderr[-3000:]
    keys = None
    for name in methods:
        run = tmp_path / "runs" / name
        assert not (run / "error.json").exists(), (run / "error.json").read_text()[-3000:]
        metrics = json.loads((run / "metrics.json").read_text())
        assert set(metrics) >= KEYS, f"{name}: metrics.json lacks {sorted(KEYS - set(metrics))}"
        keys = keys or set(metrics)
        assert set(metrics) == keys, f"{name}: metrics.json keys differ from {methods[0]}'s"
        assert metrics["experiment"] == name and metrics["method"]["name"] == name
        assert 0 < metrics["psnr"] < 100 and 0 < metrics["ssim"] <= 1
        frames = (run / "frames.csv").read_text().splitlines()
        assert len(frames) > 1 and frames[0].startswith("scene,frame,psnr")
    noisy = json.loads((tmp_path / "runs" / "noisy" / "metrics.json").read_text())
    assert noisy["psnr"] == pytest.approx(noisy["input_psnr"]) and noisy["params_m"] == 0
    if HAS_PYOIDN:
        oidn = json.loads((tmp_path / "runs" / "oidn" / "metrics.json").read_text())
        assert oidn["psnr"] > oidn["input_psnr"], "OIDN should improve on its noisy input"
        assert oidn["params_m"] is None and oidn["macs_g"] is None  # its own network: unknown, not 0

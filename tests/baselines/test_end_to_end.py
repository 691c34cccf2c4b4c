"""Each baseline trains (or, for ``noisy`` and ``oidn``, skips training) and tests end to end through
``python -m mcd.run +experiment=<name>`` on real renders (the vendored Cornell box at 32x32), writing the same
``metrics.json`` keys as the two-stage model (architecture.md "Run directory")."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from mcd.core.metrics import psnr
from mcd.data import StoreBuilder
from tests.conftest import command_in_worker, compose_cfg

REPO = Path(__file__).resolve().parents[2]
METHODS = ["unet", "rae", "fastdvdnet", "dasr", "ntasad", "noisy", "oidn"]
HAS_PYOIDN = importlib.util.find_spec("pyoidn") is not None
#: architecture.md, "Run directory": the keys every run's metrics.json holds.
KEYS = {"psnr", "ssim", "rmse", "lt", "input_psnr", "input_ssim", "input_rmse", "macs_g", "params_m",
        "experiment", "method", "budget", "data_profile", "commit", "device", "wall_s", "per_scene",
        "perceptual_loss"}


DATA = ["data.width=32", "data.height=32", "data.train_crop=32", "data.val_crop=32",
        "data.frames_per_segment=8", "data.ref_spp=64", "data.train_scenes=[cbox]", "data.test_scenes=[cbox]"]


@pytest.fixture(scope="module")
def sweep(tmp_path_factory) -> Path:
    """One multirun of every baseline (OIDN only where ``pyoidn`` is installed); its sweep directory."""
    root = tmp_path_factory.mktemp("baselines")
    methods = METHODS if HAS_PYOIDN else METHODS[:-1]
    args = ["-m", f"+experiment={','.join(methods)}", f"paths.data_dir={root / 'data'}",
            f"hydra.sweep.dir={root / 'runs'}", "hydra.sweep.subdir=${experiment}", *DATA, "train.epochs=20",
            "trainer.enable_progress_bar=false"]
    res = command_in_worker("mcd.run", args, REPO, {"OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO)})
    assert res.returncode == 0, res.stderr[-3000:]
    return root


def _black_psnr(root: Path) -> dict[int, float]:
    """PSNR of an all-black output on each test frame of the sweep's store (the floor a real output beats)."""
    store = StoreBuilder.from_cfg(compose_cfg(f"paths.data_dir={root / 'data'}", *DATA))
    frames = pd.read_csv(root / "runs" / "noisy" / "frames.csv")["frame"]
    black = np.zeros((32, 32, 3), np.float32)
    return {int(f): psnr(black, store.load("cbox", int(f), "ref")) for f in frames}


@pytest.mark.slow
def test_every_baseline_runs_end_to_end(sweep: Path) -> None:
    keys = None
    black = _black_psnr(sweep)
    for name in METHODS[:-1]:
        run = sweep / "runs" / name
        assert not (run / "error.json").exists(), (run / "error.json").read_text()[-3000:]
        metrics = json.loads((run / "metrics.json").read_text())
        assert set(metrics) >= KEYS, f"{name}: metrics.json lacks {sorted(KEYS - set(metrics))}"
        keys = keys or set(metrics)
        assert set(metrics) == keys, f"{name}: metrics.json keys differ from {METHODS[0]}'s"
        assert metrics["experiment"] == name and metrics["method"]["name"] == name
        assert 0 < metrics["ssim"] <= 1
        frames = pd.read_csv(run / "frames.csv")
        assert list(frames.columns[:3]) == ["scene", "frame", "psnr"] and len(frames) == len(black)
        for f, value in zip(frames["frame"], frames["psnr"], strict=True):
            assert value > black[int(f)] + 3, f"{name}, frame {f}: {value:.2f} dB is near a black output's"
        assert metrics["psnr"] == pytest.approx(frames["psnr"].mean())
    noisy = json.loads((sweep / "runs" / "noisy" / "metrics.json").read_text())
    assert noisy["psnr"] == pytest.approx(noisy["input_psnr"]) and noisy["params_m"] == 0


@pytest.mark.slow
@pytest.mark.skipif(not HAS_PYOIDN, reason="pyoidn is not installed (the optional extra mcd[oidn])")
def test_oidn_runs_end_to_end_and_improves_its_input(sweep: Path) -> None:
    oidn = json.loads((sweep / "runs" / "oidn" / "metrics.json").read_text())
    assert oidn["psnr"] > oidn["input_psnr"], "OIDN should improve on its noisy input"
    # its own network, counted in shape (mcd/models/baselines/oidn_network.py): 0.92 M parameters
    assert oidn["params_m"] == pytest.approx(0.92, abs=0.01) and oidn["macs_g"] > 0

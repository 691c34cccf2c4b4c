"""The paper's training path at the paper's shapes, on CPU, in CI: ``capacity=paper`` row F
on a 1920x1080 store, packed into the training store, 256x256 crops read by two loader workers, two DDP
processes on gloo, a few real steps (tests/scale/paper_smoke_run.py trains; this test writes the store and
checks)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mcd.data.buffers import CHANNELS
from tests.scale.paper_smoke_run import write_store

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_paper_model_trains_on_a_1080p_training_store_with_ddp_and_workers(tmp_path):
    data_dir, out = tmp_path / "data", tmp_path / "out"
    out.mkdir()
    buffers = write_store(str(data_dir))
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1", "HYDRA_FULL_ERROR": "1"}
    script = REPO / "tests" / "scale" / "paper_smoke_run.py"
    proc = subprocess.run([sys.executable, str(script), str(data_dir), str(out)], cwd=REPO, env=env,
                          capture_output=True, text=True, timeout=900)
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log[-5000:]
    assert "distributed_backend=gloo" in log and "Starting with 2 processes" in log

    # the training store: 1080p frames in tiles, row F's 31 channels, the 6 non-test frames packed once
    store = data_dir / "paper1080" / ".train_float32"
    assert np.load(store / "synth.npy", mmap_mode="r").shape == (7, 17, 30, 31, 64, 64)
    packed = json.loads((store / "synth.json").read_text())["frames"]
    assert sorted(packed, key=int) == [str(f) for f in range(1, 7)]

    ranks = [json.loads((out / f"rank{r}.json").read_text()) for r in range(2)]
    channels = sum(CHANNELS[b] for b in buffers)
    assert channels == 31
    for r in ranks:
        assert r["world"] == 2 and r["global_step"] == 2 and len(r["steps"]) == 2 and r["finite_weights"]
        assert r["num_workers"] == 2 and r["persistent_workers"] and r["train_store"] == str(store)
        assert not r["reads_in_this_process"]  # the workers read the store, each with its own maps
        for step in r["steps"]:
            assert set(step["shapes"]) == {*buffers, "frame"}
            assert all(step["shapes"][b] == [1, 2, CHANNELS[b], 256, 256] for b in buffers)
            assert np.isfinite(step["loss"]) and step["loss"] > 0
    # each epoch, each rank trained on its own clip of the two
    for epoch in (0, 1):
        clips = [next(s["frames"] for s in r["steps"] if s["epoch"] == epoch) for r in ranks]
        assert sorted(clips) == [[3, 4], [5, 6]]

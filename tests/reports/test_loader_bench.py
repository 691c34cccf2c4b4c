"""``python -m mcd.bench --loader --json`` (mcd/bench/loader.py, mcd/data/loader_rate.py): one run
measures the EXR path and the training store, warm and cold, at a small shape here (the paper's shape is the
command's default; docs/training_store.md has its figures)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_loader_bench_json_reports_both_paths_in_one_run(tmp_path):
    cmd = [sys.executable, "-m", "mcd.bench", "loader", "--json", "--width", "320", "--height", "200",
           "--frames", "7", "--crop", "96", "--seconds", "0.5", "--dir", str(tmp_path)]
    proc = subprocess.run(cmd, cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)}, capture_output=True,
                          text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    figures = ("clips_per_s", "cold_clips_per_s", "exr_clips_per_s")
    assert all(out[k] > 0 for k in figures) and out["worker_rss_mb"] > 0
    # row F's buffers, 31 channels; the training store beats whole-frame EXR decodes even at this size
    assert out["shape"]["channels"] == 31 and "motion" not in out["shape"]["buffers"]
    assert out["clips_per_s"] > 3 * out["exr_clips_per_s"] and out["speedup"] > 3
    assert out["bound"]["exr_clips_per_s"] in ("decode", "disk") and out["bound"]["clips_per_s"] == "memory"
    # the cold figure really read from storage: about the crops' tiles (1 to 4 times the crop), not less
    crop_mb = out["crop_mb_per_clip"]
    assert out["bound"]["cold_clips_per_s"] == "disk"
    assert crop_mb <= out["disk_mb_per_clip"]["cold_clips_per_s"] <= 4 * crop_mb
    assert out["clips_timed"]["exr_clips_per_s"] >= 2 and out["commit"] and out["machine"].startswith("CPU")
    assert (tmp_path / "exr" / "loaderbench" / "synthetic" / "manifest.json").is_file()  # --dir keeps stores


@pytest.mark.slow
def test_the_measurement_core_imports_neither_lightning_nor_hydra():
    code = ("import sys, mcd.data.loader_rate; bad = {'lightning', 'hydra'} & set(sys.modules); "
            "assert not bad, bad")
    subprocess.run([sys.executable, "-c", code], cwd=REPO, env={**os.environ, "PYTHONPATH": str(REPO)},
                   check=True)

"""What ``python -m mcd.report`` does with folders and run records it cannot
use. Defect 17: an empty or missing folder printed a traceback around its clear message. The command runs
for real."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tests.conftest import report_in_worker

ROOT = Path(__file__).resolve().parents[2]


def _report_process(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    """``python -m mcd.report <args> --out <tmp_path>/reports --name t --no-viewer`` in a fresh interpreter,
    in `tmp_path`: for what only a process shows (a wait bounded by the timeout, every line on stderr)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "mcd.report", *args, "--out", str(tmp_path / "reports"),
                           "--name", "t", "--no-viewer"], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=300)


def _report(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    """The same command as :func:`_report_process`, run in this process
    (:func:`tests.conftest.report_in_worker`)."""
    return report_in_worker([*args, "--out", str(tmp_path / "reports"), "--name", "t", "--no-viewer"],
                            tmp_path)


@pytest.mark.parametrize(("kind", "message"), [
    ("empty", "no run directories (metrics.json / error.json / .hydra) under"),
    ("missing", "no such directory"),
    ("a_file", "no run directories (metrics.json / error.json / .hydra) under"),
])
@pytest.mark.slow
def test_defect17_an_empty_or_missing_folder_is_one_line_without_a_traceback(tmp_path, kind, message):
    given = tmp_path / kind
    if kind == "empty":
        given.mkdir()
    elif kind == "a_file":
        given.write_text("not a folder\n")
    proc = _report_process(tmp_path, str(given))
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0]
    assert str(given) in lines[0]
    assert not (tmp_path / "reports").exists()


def _job(root: Path, name: str, metrics: dict) -> Path:
    d = root / name
    (d / ".hydra").mkdir(parents=True)
    (d / ".hydra" / "config.yaml").write_text(f"experiment: {metrics['experiment']}\nbudget: 4\n"
                                              "sweep_name: baselines\n")
    (d / "metrics.json").write_text(json.dumps(metrics))
    pd.DataFrame({"scene": ["cbox"] * 2, "frame": [0, 1], "psnr": [30.0, 31.0]}).to_csv(d / "frames.csv",
                                                                                        index=False)
    return d


GARBAGE = np.random.default_rng(0).bytes(4096)


@pytest.mark.parametrize(("damage", "file", "why"), [
    ("frames_bytes", "frames.csv", "is corrupt"),
    ("psnr_1e308", "metrics.json", "psnr=1e+308 outside [0, 100]"),
    ("ssim_minus_5", "metrics.json", "ssim=-5 outside [-1, 1]"),
    ("config_bytes", ".hydra/config.yaml", "is corrupt (not a readable Hydra record"),
])
@pytest.mark.slow
def test_defect18_a_damaged_run_record_fails_that_run_and_the_report_goes_on(tmp_path, damage, file, why):
    sweep = tmp_path / "multirun"
    _job(sweep, "F_spp4", {"psnr": 30.5, "ssim": 0.9, "experiment": "F", "budget": 4})
    bad = _job(sweep, "unet_spp4", {"psnr": 29.0, "ssim": 0.8, "experiment": "unet", "budget": 4})
    if damage == "psnr_1e308":
        (bad / file).write_text(json.dumps({"psnr": 1e308, "ssim": 0.8, "experiment": "unet", "budget": 4}))
    elif damage == "ssim_minus_5":
        (bad / file).write_text(json.dumps({"psnr": 29.0, "ssim": -5, "experiment": "unet", "budget": 4}))
    else:
        (bad / file).write_bytes(GARBAGE)
    proc = _report(tmp_path, str(sweep))
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    err = proc.stderr.replace(" is corrupt (a score out of range: ", " ")
    assert f"error: {bad.resolve() / file} {why}" in err, proc.stderr
    readme = (tmp_path / "reports" / "t" / "README.md").read_text()
    assert "2 found, 1 finished, 1 failed" in readme and "unet_spp4" in readme
    assert not re.search(r"\d{20}", (tmp_path / "reports" / "t" / "table1.md").read_text())  # no 309 digits

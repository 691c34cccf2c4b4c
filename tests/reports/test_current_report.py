"""scripts/current_report.sh (docs/benchmark.md "Reports"): its report stage turns the jobs of every sweep of
the current report into one report folder, the index and README.md's results; a later session on other code
is refused, so that the report is one commit's code. The training stages are the sweeps of
tests/reports/test_sweep_to_report.py; a whole run is tens of CPU-hours."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from mcd.reporting import index

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "scripts" / "current_report.sh"


def _script(tmp_path: Path, *stages: str, **env: str) -> subprocess.CompletedProcess:
    full = {**os.environ, "PYTHONPATH": str(REPO), "PY": sys.executable, "DATA": "tiny",
            "MULTIRUN": str(tmp_path / "multirun"), "OUT": str(tmp_path / "reports"), **env}
    return subprocess.run(["bash", str(SCRIPT), *stages], env=full, capture_output=True, text=True,
                          timeout=600)


def _job(sweep: Path, exp: str, psnr: float) -> None:
    d = sweep / f"{exp}_spp4"
    (d / ".hydra").mkdir(parents=True)
    (d / ".hydra" / "config.yaml").write_text(
        f"experiment: {exp}\nbudget: 4\nsweep_name: {sweep.parent.name}\ndata:\n  name: tiny\n")
    (d / ".hydra" / "overrides.yaml").write_text(f"- +experiment={exp}\n")
    (d / "metrics.json").write_text(json.dumps({"psnr": psnr, "ssim": 0.7, "rmse": 0.2, "flip": 0.3,
                                                "experiment": exp, "budget": 4, "train_steps": 3}))


@pytest.mark.slow
def test_the_report_stage_writes_the_report_the_index_and_the_readme_results(tmp_path):
    root = tmp_path / "multirun"
    _job(root / "ablation" / "tiny_current", "F", 21.0)
    _job(root / "ablation" / "tiny_current", "A", 19.0)
    _job(root / "baselines" / "tiny_current", "ntasad", 20.0)
    readme = tmp_path / "README.md"
    readme.write_text(f"# x\n\n## Results\n\n{index.BEGIN}\n{index.END}\n")
    proc = _script(tmp_path, "report", REPORT_ARGS=f"--current tiny_current --readme {readme}")
    assert proc.returncode == 0, proc.stderr[-3000:]
    report = tmp_path / "reports" / "tiny_current"
    t1 = pd.read_csv(report / "table1.csv").set_index("experiment")
    assert t1.loc["F", "PSNR"] == 21.0 and t1.loc["ntasad", "PSNR"] == 20.0  # every sweep in one report
    assert "train.max_steps=1000" in (report / "README.md").read_text()  # the stated budget (the default)
    assert "**tiny_current** (current)" in (tmp_path / "reports" / "README.md").read_text()
    assert "[`tiny_current`](reports/tiny_current/README.md)" in readme.read_text()
    assert "21.00 · 70.00 · 200.00 · 30.00" in readme.read_text()


def test_a_session_on_other_code_is_refused(tmp_path):
    mark = tmp_path / "multirun" / "tiny_current.commit"
    mark.parent.mkdir()
    mark.write_text("0123456789abcdef\n")
    proc = _script(tmp_path, "seeds")
    assert proc.returncode == 2 and "0123456789abcdef" in proc.stderr and str(mark) in proc.stderr
    assert not (tmp_path / "multirun" / "seeds").exists()  # nothing ran

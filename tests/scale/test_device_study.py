"""``scripts/device_study.sh`` runs first time (docs/scale.md "The scaling study on a GPU"): on the CPU, on a
32x32 Cornell-box profile, with every default method and a seconds budget, it renders, trains and tests each
method at once, and writes what a device call can bring back (at most 8 files of at most 16 MiB, no deeper
than two folders), and its archive of run directories is what ``python -m mcd.report`` reads back."""

from __future__ import annotations

import csv
import os
import subprocess
import sys
import tarfile
from pathlib import Path

import pytest

from tests.conftest import report_in_worker, store32_overrides

REPO = Path(__file__).resolve().parents[2]
SCRIPT = REPO / "scripts" / "device_study.sh"


def _default_methods() -> list[str]:
    for line in SCRIPT.read_text().splitlines():
        if line.startswith("METHODS="):
            return line.split(":-", 1)[1].rstrip("}").split()
    raise AssertionError("scripts/device_study.sh sets no METHODS default")


@pytest.mark.slow
def test_device_study_runs_on_cpu_and_its_archive_reports(tmp_path):
    out, data = tmp_path / "out", tmp_path / "unused"
    extra = [o for o in store32_overrides(data) if not o.startswith(("data=", "paths.data_dir="))]
    extra += ["data.transfer_scenes=[]", "data.num_workers=0", "train.val_every_steps=2"]
    methods = _default_methods()
    env = {**os.environ, "OUT": str(out), "PY": sys.executable, "ACCEL": "cpu", "PROFILE": "tiny",
           "MAX_STEPS": "3", "SECONDS_TOTAL": "300", "TEST_RESERVE_S": "60", "EXTRA": " ".join(extra),
           "OMP_NUM_THREADS": "1"}
    proc = subprocess.run(["bash", str(SCRIPT)], cwd=REPO, env=env, capture_output=True, text=True,
                          timeout=600)
    log = (out / "study.log").read_text() if (out / "study.log").exists() else ""
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:] + log[-5000:]
    assert "== render: exit 0" in log, log[-5000:]

    # what a device call brings back: at most 8 files of at most 16 MiB, no deeper than $OUT/a/b/file
    files = [p for p in out.rglob("*") if p.is_file()]
    assert 0 < len(files) <= 8 and all(p.stat().st_size <= 16 * 2**20 for p in files)
    assert all(len(p.relative_to(out).parts) <= 3 for p in files)
    assert sorted(p.name for p in files) == ["machine.txt", "runs.tar.gz", "study.log", "summary.csv"]

    rows = {r["experiment"]: r for r in csv.DictReader((out / "summary.csv").open())}
    assert sorted(rows) == sorted(methods)
    for m in methods:
        assert f"== {m}: exit 0" in log, log[-5000:]
        assert int(rows[m]["train_steps"]) == 3 and float(rows[m]["psnr"]) > 0, rows[m]

    runs = tmp_path / "back"
    with tarfile.open(out / "runs.tar.gz") as tar:
        names = tar.getnames()
        assert not any(n.endswith((".exr", ".png", "last.ckpt")) for n in names)
        tar.extractall(runs, filter="data")
    assert sorted(p.parent.name for p in (runs / "runs").glob("*/metrics.json")) == sorted(methods)
    report = report_in_worker([str(runs / "runs"), "--out", str(tmp_path / "reports"), "--name", "gpu",
                               "--no-viewer"], REPO)
    assert report.returncode == 0, report.stderr[-3000:]
    table = {r["experiment"]: r for r in csv.DictReader((tmp_path / "reports" / "gpu" / "table1.csv").open())}
    assert all(table[m]["status"] == "ok" and float(table[m]["PSNR"]) > 0 for m in methods), table

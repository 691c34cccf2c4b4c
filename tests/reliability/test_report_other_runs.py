"""Campaign 9, part 2 (notes/reliability_campaigns.md): ``python -m mcd.report`` of other runs under a name
an earlier report used, and of a run at a shallow path. A report whose runs saved no samples (or had no row
of the full method) kept the earlier report's viewer, linked from its README as its own, and its strips:
they showed other runs' pictures and metrics. Now they are kept only for a report regenerated from its own
run records (``mcd.reporting.records.from_own_records``; ``tests/reports/test_viewer.py`` keeps that case).
A run directory at ``/tmp/<run>`` made its record folder the run itself (the key was absolute): the copy met
the run's own files and the report ended in a SameFileError traceback after its tables. The command runs
for real on crafted run records."""

from __future__ import annotations

import hashlib
import shutil
import tempfile
from pathlib import Path

import pytest

from mcd.report import main
from tests.reliability.test_report_inputs import _job
from tests.reliability.test_report_record_shapes import _samples


def _sweep(root: Path) -> tuple[Path, Path]:
    """A sweep of F (with samples) and the U-Net (without); returns the sweep and the U-Net's run."""
    sweep = root / "multirun"
    _job(sweep, "F_spp4", {"psnr": 30.5, "ssim": 0.9, "experiment": "F", "budget": 4})
    _samples(sweep / "F_spp4", 32, ("output", "reference", "noisy_4spp"))
    return sweep, _job(sweep, "unet_spp4", {"psnr": 29.0, "ssim": 0.8, "experiment": "unet", "budget": 4})


@pytest.mark.slow
def test_a_report_of_other_runs_under_a_used_name_keeps_no_earlier_viewer_or_strips(tmp_path):
    sweep, unet = _sweep(tmp_path)
    alone = tmp_path / "alone" / "unet_spp4"
    shutil.copytree(unet, alone)
    out = tmp_path / "reports"
    report = out / "x"
    args = ["--out", str(out), "--name", "x", "--bench", str(tmp_path / "none")]
    main([str(sweep), *args])
    assert (report / "viewer" / "index.html").is_file() and (report / "strips" / "cbox.png").is_file()

    main([str(alone.parent), *args])  # the U-Net alone: no samples of the full method
    assert not (report / "viewer").exists()
    assert not (report / "strips").exists()
    assert "viewer/index.html" not in (report / "README.md").read_text()


def test_a_run_at_a_shallow_path_is_reported_and_its_records_copied(tmp_path):
    _, unet = _sweep(tmp_path)
    shallow = Path(tempfile.mkdtemp(prefix="mcd-report-run-", dir="/tmp"))  # /tmp/<run>: three path parts
    try:
        shutil.copytree(unet, shallow, dirs_exist_ok=True)
        before = {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in shallow.rglob("*") if p.is_file()}
        main([str(shallow), "--out", str(tmp_path / "reports"), "--name", "x", "--bench",
              str(tmp_path / "none"), "--no-viewer"])
        kept = tmp_path / "reports" / "x" / "runs" / "tmp" / shallow.name / "metrics.json"
        assert kept.read_bytes() == (shallow / "metrics.json").read_bytes()
        assert {p: hashlib.sha256(p.read_bytes()).hexdigest() for p in shallow.rglob("*") if p.is_file()} \
            == before
    finally:
        shutil.rmtree(shallow)


def test_a_users_folder_at_the_reports_name_is_refused_and_kept(tmp_path):
    """A folder at ``<out>/<name>`` without a report's README.md that holds names a report writes (a user's
    own ``runs/``, ``table1.csv``) had them deleted or overwritten; now the report is refused before anything
    is written."""
    _, unet = _sweep(tmp_path)
    mine = tmp_path / "reports" / "x"
    (mine / "runs").mkdir(parents=True)
    (mine / "runs" / "notes.txt").write_text("my notes\n")
    (mine / "table1.csv").write_text("my,table\n")
    with pytest.raises(SystemExit, match="no report README.md, so no report wrote them"):
        main([str(unet), "--out", str(tmp_path / "reports"), "--name", "x", "--bench",
              str(tmp_path / "none")])
    assert (mine / "runs" / "notes.txt").read_text() == "my notes\n"
    assert (mine / "table1.csv").read_text() == "my,table\n"
    assert sorted(p.name for p in mine.iterdir()) == ["runs", "table1.csv"]

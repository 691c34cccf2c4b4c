"""Campaign 10, part 2 (notes/reliability_campaigns.md): one damaged EXR in a run's ``samples/`` (random
bytes at F's ``0001_output.exr``, or the U-Net's ``0000_output.exr`` cut to 100 bytes) ended ``mcd.report``
in a CorruptEXRError traceback after its tables, without README.md, findings or viewer (under an existing
name: the new tables beside the old README). The damaged picture is left out of the strips and the viewer
now (``mcd.reporting.strips.read_sample``), the report is written whole, and the command exits 1 naming the
file. The session's real ``ab_sweep`` (rows A and F with their samples), copied."""

from __future__ import annotations

import pytest

from tests.conftest import copy_sweep, report_in_worker


@pytest.mark.slow
def test_a_damaged_sample_is_left_out_and_named_and_the_report_is_whole(ab_sweep, tmp_path):
    copy_sweep(ab_sweep, tmp_path)
    jobs = tmp_path / "multirun" / "ablation" / "tiny"
    garbage = jobs / "F_spp4" / "samples" / "cbox" / "0001_output.exr"
    garbage.write_bytes(bytes(range(256)) * 12)
    cut = jobs / "A_spp4" / "samples" / "cbox" / "0000_output.exr"
    cut.write_bytes(cut.read_bytes()[:100])
    proc = report_in_worker([str(jobs), "--out", str(tmp_path / "reports"), "--name", "t"], tmp_path)
    assert proc.returncode == 1, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr, proc.stderr[-3000:]
    for path in (garbage, cut):
        assert f"error: {path}: truncated or corrupt EXR" in proc.stderr, proc.stderr[-3000:]
    report = tmp_path / "reports" / "t"
    assert (report / "README.md").is_file() and (report / "findings.json").is_file()
    assert (report / "viewer" / "index.html").is_file() and (report / "strips" / "cbox.png").is_file()

"""Campaign 10, part 2 (notes/reliability_campaigns.md): a hard link in a report's folder at a name the
report writes (``table1.csv`` sharing the bytes of a user's ``user.csv`` outside it) had the user's file
overwritten by the next report, exit 0: most report files are written in place, and campaign 8's check
refused symbolic links only. ``mcd.report.check_out`` refuses such a file before anything is written, naming
it, and the user's file keeps its bytes. The command runs for real."""

from __future__ import annotations

import os

import pytest

from tests.reliability.test_report_inputs import _job, _report


@pytest.mark.slow
@pytest.mark.parametrize("name", ["table1.csv", "per_frame/cbox_psnr.png"])
def test_a_hard_link_where_the_report_writes_is_refused_and_the_users_file_kept(tmp_path, name):
    sweep = tmp_path / "multirun"
    for exp in ("F", "unet"):
        _job(sweep, f"{exp}_spp4", {"psnr": 30.0, "ssim": 0.9, "experiment": exp, "budget": 4})
    assert _report(tmp_path, str(sweep)).returncode == 0
    user = tmp_path / "user.csv"
    user.write_text("the user's own bytes\n")
    target = tmp_path / "reports" / "t" / name
    target.unlink()
    os.link(user, target)
    proc = _report(tmp_path, str(sweep))
    assert proc.returncode != 0 and "Traceback" not in proc.stderr, proc.stderr
    assert f"{target}: a link where the report writes (a hard link" in proc.stderr, proc.stderr
    assert user.read_text() == "the user's own bytes\n"

"""Campaign 10, part 2 (notes/reliability_campaigns.md): a report named ``README.md`` (``--name``, or the
runs' ``data_profile`` from their ``metrics.json``) was written as the folder ``<out>/README.md``, where the
reports index goes; the index then ended in an IsADirectoryError traceback, after this report and after every
later report into that root. The name is refused now before anything is written. The command runs for
real."""

from __future__ import annotations

import json

import pytest

from tests.conftest import report_in_worker
from tests.reliability.test_report_inputs import _job


def _report(tmp_path, *args):
    return report_in_worker([*args, "--out", str(tmp_path / "reports"), "--no-viewer"], tmp_path)


@pytest.mark.parametrize("how", ["--name", "data_profile"])
@pytest.mark.slow
def test_a_report_named_like_the_index_is_refused_before_anything_is_written(tmp_path, how):
    sweep = tmp_path / "multirun"
    profile = {"data_profile": "readme.MD"} if how == "data_profile" else {}
    for exp in ("F", "unet"):
        _job(sweep, f"{exp}_spp4", {"psnr": 30.0, "ssim": 0.9, "experiment": exp, "budget": 4, **profile})
    proc = _report(tmp_path, str(sweep), *(["--name", "README.md"] if how == "--name" else []))
    assert proc.returncode != 0 and "Traceback" not in proc.stderr, proc.stderr
    assert "the name of the reports index (<out>/README.md)" in proc.stderr, proc.stderr
    assert not (tmp_path / "reports").exists()
    proc = _report(tmp_path, str(sweep), "--name", "t")  # a later report of the root is whole
    assert proc.returncode == 0, proc.stderr
    assert (tmp_path / "reports" / "README.md").is_file() and json.loads(
        (tmp_path / "reports" / "t" / "findings.json").read_text()) is not None

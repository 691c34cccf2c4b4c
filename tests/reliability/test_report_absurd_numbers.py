"""Campaign 10, part 2 (notes/reliability_campaigns.md): a run record's number that no run writes
(``"rmse": 1e300``, ``"wall_s": 1e300``, an ``edges.json`` ``edge_effect`` of 1e300) was printed in full:
Table 1's rMSE cell and the README's wall time held 300-digit numbers, exit 0. Such a run is failed, named
with its file and key (``mcd.reporting.runs.absurd_numbers``), and the others are reported. The command runs
for real."""

from __future__ import annotations

import json
import re

import pytest

from mcd.reporting.select import to_markdown
from tests.reliability.test_report_inputs import _job, _report


@pytest.mark.parametrize(("file", "fields", "named"), [
    ("metrics.json", {"rmse": 1e300}, "rmse=1e+300"),
    ("metrics.json", {"wall_s": 1e300, "params_m": -1e300}, "wall_s=1e+300, params_m=-1e+300"),
    ("metrics.json", {"train_s": -5.0}, "train_s=-5"),
    ("metrics.json", {"per_scene": {"cbox": {"rmse": 1e39}}}, "per_scene.cbox.rmse=1e+39"),
    ("edges.json", {"edge_effect": 1e300}, "edge_effect=1e+300"),
])
@pytest.mark.slow
def test_a_number_no_run_records_fails_that_run_naming_the_key(tmp_path, file, fields, named):
    sweep = tmp_path / "multirun"
    _job(sweep, "F_spp4", {"psnr": 30.5, "ssim": 0.9, "experiment": "F", "budget": 4})
    bad = _job(sweep, "unet_spp4", {"psnr": 29.0, "ssim": 0.8, "experiment": "unet", "budget": 4})
    path = bad / file
    old = json.loads(path.read_text()) if path.is_file() else {}
    path.write_text(json.dumps({**old, **fields}))
    proc = _report(tmp_path, str(sweep))
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    assert f"error: {bad.resolve() / file} is corrupt (a number no run records: {named})" in proc.stderr, \
        proc.stderr
    report = tmp_path / "reports" / "t"
    assert "2 found, 1 finished, 1 failed" in (report / "README.md").read_text()
    for md in report.glob("*.md"):
        assert not re.search(r"\d{20}", md.read_text()), md


def test_an_hdr_error_in_range_is_kept_and_its_cell_stays_short():
    """The control: an rMSE of 1e6 (an HDR error, real) is a result; x1e3 in Table 1 it reads 1e+09."""
    import pandas as pd

    text = to_markdown(pd.DataFrame({"rMSE": [1e6 * 1e3, 12.345]}))
    assert "| 1e+09 |" in text and "| 12.35 |" in text


@pytest.mark.parametrize(("where", "value", "named"), [
    ("config", -5, "train.max_steps=-5: give a whole number >= 1 or null"),
    ("config", 10**50, "train.max_steps=1e+50"),
    ("metrics", 10**30, "train_steps=1e+30"),
])
def test_a_step_budget_no_run_records_fails_that_run_in_the_scaling_report(tmp_path, where, value, named):
    """``train.max_steps: -5`` in a run's config made a scale point of -5 steps, exit 0; ``1e50`` (or
    ``train_steps`` of 1e30 where no ``max_steps`` is set) ended the scaling report in a traceback after
    half its tables were written."""
    sweep = tmp_path / "multirun"
    for i, exp in enumerate(("F", "unet")):
        run = _job(sweep, f"{exp}_spp4", {"psnr": 30.5 - i, "ssim": 0.9, "experiment": exp, "budget": 4,
                                          "seed": 0, "train_steps": 100})
        steps = value if (where, exp) == ("config", "unet") else "null" if where == "metrics" else 100
        with (run / ".hydra" / "config.yaml").open("a") as f:
            f.write(f"train:\n  max_steps: {steps}\n")
    bad = sweep / "unet_spp4"
    if where == "metrics":
        (bad / "metrics.json").write_text(json.dumps({**json.loads((bad / "metrics.json").read_text()),
                                                      "train_steps": value}))
    proc = _report(tmp_path, str(sweep), "--kind", "scaling")
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    file = bad.resolve() / (".hydra/config.yaml" if where == "config" else "metrics.json")
    assert f"error: {file} is corrupt (" in proc.stderr and named in proc.stderr, proc.stderr
    assert (tmp_path / "reports" / "t" / "README.md").is_file()


@pytest.mark.parametrize(("column", "value", "named"), [
    ("ssim", 1e300, "a ssim outside [-1, 1]"),
    ("flip", -1e300, "a flip outside [0, 1]"),
    ("rmse", 1e300, "a rmse outside [0, 3.40282e+38]"),
])
def test_a_frames_csv_score_out_of_its_range_fails_that_run(tmp_path, column, value, named):
    """``frames.csv`` was held to the range of its PSNR only: an SSIM of 1e300 reached the viewer's data and
    the per-frame table, exit 0."""
    sweep = tmp_path / "multirun"
    _job(sweep, "F_spp4", {"psnr": 30.5, "ssim": 0.9, "experiment": "F", "budget": 4})
    bad = _job(sweep, "unet_spp4", {"psnr": 29.0, "ssim": 0.8, "experiment": "unet", "budget": 4})
    frames = bad / "frames.csv"
    frames.write_text(f"scene,frame,psnr,{column}\ncbox,0,30.0,{value}\ncbox,1,31.0,\n")
    proc = _report(tmp_path, str(sweep))
    assert proc.returncode == 1, proc.stderr
    assert f"error: {frames.resolve()} is corrupt ({named})" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr

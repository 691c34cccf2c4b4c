"""``mcd.report`` named a corrupt ``metrics.json`` as a job "killed or still running"
and exited 0, and showed ``"psnr": "NaN"`` as a finished job. A corrupt record makes the job failed, named
with its file, and the command exits 1 after writing the report."""

from __future__ import annotations

import json

import pytest

from mcd.report import main
from mcd.reporting.runs import find_runs


def _job(root, name, metrics_text):
    d = root / name
    (d / ".hydra").mkdir(parents=True)
    (d / ".hydra" / "config.yaml").write_text("experiment: F\nbudget: 4\nsweep_name: ablation\n")
    (d / "metrics.json").write_text(metrics_text)
    return d


def test_a_corrupt_metrics_json_is_a_named_failure_and_the_report_exits_1(tmp_path, capsys):
    sweep = tmp_path / "multirun"
    _job(sweep, "truncated", '{"psnr": 30.1, "ssim": 0.9')
    _job(sweep, "nan_text", json.dumps({"psnr": "NaN", "experiment": "F", "budget": 4}))
    _job(sweep, "a_list", "[1, 2]")
    _job(sweep, "sound", json.dumps({"psnr": 30.0, "ssim": None, "experiment": "F", "budget": 4}))
    runs = {r.path.name: r for r in find_runs([sweep])}
    assert {k: r.status for k, r in runs.items()} == {"truncated": "failed", "nan_text": "failed",
                                                      "a_list": "failed", "sound": "ok"}
    for name, why in (("truncated", "not readable JSON"), ("nan_text", "not a number: psnr='NaN'"),
                      ("a_list", "a JSON list, not an object")):
        message = runs[name].error_message
        assert message.startswith(f"{sweep.resolve() / name / 'metrics.json'} is corrupt ({why}"), message
        assert "killed" not in message

    with pytest.raises(SystemExit) as stop:
        main([str(sweep), "--out", str(tmp_path / "reports"), "--name", "t",
              "--bench", str(tmp_path / "none")])
    assert stop.value.code == 1
    err = capsys.readouterr().err
    assert err.count("is corrupt") == 3 and "nan_text/metrics.json is corrupt" in err
    readme = (tmp_path / "reports" / "t" / "README.md").read_text()
    assert "1 finished, 3 failed" in readme  # the report is written, the three jobs listed as failed

"""Strings from a run's records (``<script>``, ``<img onerror>`` in ``metrics.json``
and ``error.json``) went raw into a report's README.md and ``reports/README.md``. Every such string passes
``mcd.reporting.markdown_text.escape``: no tag opens, no table cell splits. ``python -m mcd.report`` for
real on run directories."""

from __future__ import annotations

import json
import re

import pytest

from mcd.report import main

SCRIPT = "<script>alert(1)</script>"
IMG = "<img src=x onerror=alert(1)>"


def _job(root, name, experiment, metrics=None, error=None):
    d = root / name
    (d / ".hydra").mkdir(parents=True)
    (d / ".hydra" / "config.yaml").write_text(f"experiment: {experiment}\nbudget: 4\nsweep_name: baselines\n")
    if metrics is not None:
        (d / "metrics.json").write_text(json.dumps(metrics))
    if error is not None:
        (d / "error.json").write_text(json.dumps(error))


def test_strings_from_run_records_are_escaped_in_the_reports_markdown(tmp_path, capsys):
    sweep = tmp_path / "multirun"
    hostile = {"psnr": 30.0, "ssim": 0.9, "experiment": "F", "budget": 4, "commit": IMG,
               "device": f"{SCRIPT} | cell", "data_profile": "tiny"}
    _job(sweep, "F_spp4", "F", metrics=hostile)
    _job(sweep, "unet_spp4", "unet", metrics={**hostile, "experiment": f"unet{IMG}"})
    _job(sweep, "A_spp4", "A", error={"error": f"{SCRIPT}\n| injected | row |"})
    main([str(sweep), "--out", str(tmp_path / "reports"), "--name", "t", "--bench", str(tmp_path / "none"),
          "--no-viewer"])
    for page in (tmp_path / "reports" / "t" / "README.md", tmp_path / "reports" / "README.md"):
        text = page.read_text()
        assert not re.search(r"<(script|img)", text, re.I), f"{page}: a tag from the records is raw"
    readme = (tmp_path / "reports" / "t" / "README.md").read_text()
    assert "&lt;script&gt;" not in readme  # only < is replaced
    assert "&lt;script>alert(1)&lt;/script>" in readme and "&lt;img src=x onerror=alert(1)>" in readme
    assert "\n| injected" not in readme  # the error's line break starts no table row


@pytest.mark.parametrize(("raw", "escaped"), [
    (SCRIPT, "&lt;script>alert(1)&lt;/script>"),
    ("a|b\nc", "a\\|b c"),
    ("F >= OIDN - 1 dB", "F >= OIDN - 1 dB"),
])
def test_escape_is_plain_text_and_idempotent(raw, escaped):
    from mcd.reporting.markdown_text import escape

    assert escape(raw) == escaped and escape(escaped) == escaped

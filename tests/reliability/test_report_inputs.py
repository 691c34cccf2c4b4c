"""Defects 17 and 18 of issue 48: what ``python -m mcd.report`` does with folders and run records it cannot
use. Defect 17: an empty or missing folder printed a traceback around its clear message. The command runs
for real."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _report(tmp_path: Path, *args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "mcd.report", *args, "--out", str(tmp_path / "reports"),
                           "--name", "t", "--no-viewer"], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=300)


@pytest.mark.parametrize(("kind", "message"), [
    ("empty", "no run directories (metrics.json / error.json / .hydra) under"),
    ("missing", "no such directory"),
    ("a_file", "no run directories (metrics.json / error.json / .hydra) under"),
])
def test_defect17_an_empty_or_missing_folder_is_one_line_without_a_traceback(tmp_path, kind, message):
    given = tmp_path / kind
    if kind == "empty":
        given.mkdir()
    elif kind == "a_file":
        given.write_text("not a folder\n")
    proc = _report(tmp_path, str(given))
    assert proc.returncode == 1, proc.stderr
    assert "Traceback" not in proc.stderr, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: ") and message in lines[0]
    assert str(given) in lines[0]
    assert not (tmp_path / "reports").exists()

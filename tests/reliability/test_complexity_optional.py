"""Without the optional ``pyoidn``, ``python -m mcd.complexity`` lists OIDN as
unavailable and prints every other row."""

from __future__ import annotations

import csv
import math
import sys

import pytest

from mcd.complexity import main


@pytest.mark.slow
def test_complexity_without_pyoidn_lists_oidn_as_unavailable(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "pyoidn", None)  # `import pyoidn` now raises ImportError
    out = tmp_path / "complexity.csv"
    main(["--experiments", "A", "oidn", "noisy", "--capacity", "cpu", "--out", str(out), "--height", "64",
          "--width", "64"])
    printed = capsys.readouterr().out
    oidn = next(line for line in printed.splitlines() if line.startswith("oidn"))
    assert "unavailable: method 'oidn' needs the optional package pyoidn" in oidn
    rows = {r["name"]: r for r in csv.DictReader(out.open())}
    assert list(rows) == ["A", "oidn", "noisy"] and float(rows["A"]["params_m"]) > 0
    assert math.isnan(float(rows["oidn"]["params_m"])) and math.isnan(float(rows["oidn"]["gmacs_1080p"]))

"""``python -m mcd.bench profile`` (mcd/bench/profile.py, docs/inference.md "Stage profile"): real
clocked calls of row F on the CPU, stage by stage, whose exclusive stages add up to the frame; a table that
does not add up is refused; the clock's attribution (mcd/core/stages.py) counted in FLOPs."""

from __future__ import annotations

import pytest
import torch

from mcd.bench import profile as inference_profile
from mcd.core.stages import FlopClock, stage
from mcd.models.complexity import flop_counter_mode


def rows_of(text: str) -> list[tuple[str, list[str]]]:
    return [(line.split(" | ")[0].strip("| ").replace("&nbsp;", ""), line.strip("| ").split(" | ")[1:])
            for line in text.splitlines() if line.startswith("| ") and not line.startswith("| stage")
            and not line.startswith("| label")]


def test_row_f_is_profiled_stage_by_stage_on_the_cpu(tmp_path):
    out = tmp_path / "profile.md"
    inference_profile.main(["--synthetic", "--size", "64x48", "--dtype", "fp32", "--warmup", "1",
                            "--repeat", "2", "--out", str(out), "capacity=cpu"])
    text = out.read_text()
    assert text.startswith("# Inference profile: F at 64x48 on the CPU")
    exclusive, _, overlapping = text.partition("| label, nested labels included")
    rows = rows_of(exclusive)
    names = [name for name, _ in rows]
    for label in ("input packing", "F_s", "Ghost conv", "adaptive render", "kernel pool", "kernel-map head",
                  "kernel application", "F_d", "L0", "L1", "L2", "L3", "L4", "PP", "SA", "output steps",
                  "other", "**sum of stages**", "**frame**"):
        assert label in names, label
    ms = [float(cells[0]) for name, cells in rows if not name.startswith("**")]
    total = dict((name, float(cells[0])) for name, cells in rows)
    assert sum(ms) == pytest.approx(total["**sum of stages**"], abs=0.01 * len(ms))
    assert abs(total["**sum of stages**"] - total["**frame**"]) <= 0.1 * total["**frame**"]
    gmacs = [float(cells[2]) for name, cells in rows if not name.startswith("**") and cells[2] != "—"]
    assert sum(gmacs) == pytest.approx(float(dict(rows)["**frame**"][2]), rel=0.01)
    inclusive = dict((name, float(cells[0])) for name, cells in rows_of(overlapping))
    assert inclusive["kernel-map head"] <= inclusive["kernel pool"] + 1e-6   # nested within its parent
    assert inclusive["SA"] <= inclusive["L4"] + 1e-6 and inclusive["L4"] <= inclusive["F_d"] + 1e-6


def test_a_table_that_does_not_add_up_is_refused(tmp_path, capsys):
    out = tmp_path / "profile.md"
    with pytest.raises(SystemExit) as exit_:       # tolerance 0: the call's time outside the clock counts
        inference_profile.main(["--synthetic", "--size", "32x32", "--dtype", "fp32", "--warmup", "0",
                                "--repeat", "1", "--tolerance", "0", "--out", str(out), "capacity=cpu"])
    assert exit_.value.code == inference_profile.REFUSED
    assert capsys.readouterr().out.startswith("REFUSED: ")
    assert not out.exists()


def test_a_nested_stage_is_not_counted_in_its_parent():
    a, b = torch.ones(8, 16), torch.ones(16, 4)
    with flop_counter_mode() as counter, FlopClock(counter) as clock:
        with stage("outer"):
            a @ b                                                   # 2 * 8 * 16 * 4 FLOPs
            with stage("inner"):
                a @ b
                a @ b
            a @ b
        a @ b                                                       # outside every label
    one = 2 * 8 * 16 * 4
    assert clock.totals() == {"": one, "outer": 2 * one, "outer/inner": 2 * one}
    assert clock.span() == 5 * one

"""``python -m mcd.bench profile`` (mcd/tools/inference_profile.py, docs/inference.md): a real profiled call
of row F on the CPU, stage by stage."""

from __future__ import annotations

from mcd.tools import inference_profile


def test_row_f_is_profiled_stage_by_stage_on_the_cpu(tmp_path):
    out = tmp_path / "profile.md"
    inference_profile.main(["--synthetic", "--size", "64x48", "--dtype", "fp32", "--warmup", "1",
                            "--out", str(out), "capacity=cpu"])
    text = out.read_text()
    assert text.startswith("# Inference profile: F at 64x48 on the CPU")
    rows = {line.split(" | ")[0].strip("| ").replace("&nbsp;", ""): line for line in text.splitlines()
            if line.startswith("| ") and not line.startswith("| stage")}
    assert {"F_s", "kernel pool", "F_d", "other", "**frame**"} <= set(rows)
    ms = {name: float(row.split(" | ")[1]) for name, row in rows.items()}
    assert all(ms[s] > 0 for s in ("F_s", "kernel pool", "F_d"))
    assert ms["F_s"] + ms["adaptive render"] + ms["kernel pool"] + ms["F_d"] <= ms["**frame**"] * 1.05
    assert ms["kernel-map head"] <= ms["kernel pool"] * 1.05  # a nested label within its parent

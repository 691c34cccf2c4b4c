"""``python -m mcd.bench profile`` (mcd/tools/inference_profile.py, docs/inference.md): a real profiled call
of row F, stage by stage, and the refusals of a device or precision the machine cannot run."""

from __future__ import annotations

import pytest
import torch

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
    stage_ms = [float(rows[s].split(" | ")[1]) for s in ("F_s", "kernel pool", "F_d")]
    frame_ms = float(rows["**frame**"].split(" | ")[1])
    assert all(t > 0 for t in stage_ms) and sum(stage_ms) <= frame_ms * 1.05


@pytest.mark.skipif(torch.cuda.is_available(), reason="checks the refusal where no GPU is present")
def test_a_gpu_profile_without_a_gpu_is_refused_naming_the_option(capsys):
    with pytest.raises(SystemExit):
        inference_profile.main(["--device", "cuda", "--synthetic"])
    assert "--device cuda: no CUDA device here" in capsys.readouterr().err


def test_fp16_on_the_cpu_is_refused(capsys):
    with pytest.raises(SystemExit):
        inference_profile.main(["--dtype", "fp16", "--synthetic"])
    assert "--dtype fp16 is for --device cuda" in capsys.readouterr().err

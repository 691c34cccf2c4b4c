"""Frames mode scores input and output against references (docs/denoise.md, "Scores of frames";
mcd/denoise/frame_scores.py): a real 32x32 Cornell-box sequence with its references, rendered by
``mcd.denoise.render_frames``."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from mcd.core.metrics import flip, psnr, ssim
from mcd.denoise.cli import run
from mcd.denoise.frames import read_frame
from tests.denoise.helpers import render_sequence, untrained_bundle


@pytest.fixture(scope="module")
def sequence(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("scored")
    render_sequence(folder, frames=2, ref_spp=64)
    return folder


def test_references_beside_the_frames_are_found_and_each_score_is_the_metrics_one(sequence, tmp_path, capsys):
    report = run([str(sequence), "-o", str(tmp_path / "out"), "--experiment", "noisy", "--no-progress"])
    scores = report["scores"]
    assert [r["frame"] for r in scores["frames"]] == ["cbox_0000", "cbox_0001"]
    e = report["exposure"]
    for row in scores["frames"]:
        noisy = read_frame(sequence / f"{row['frame']}.exr", set())["colour"] * np.float32(e)
        ref = read_frame(sequence / "reference" / f"{row['frame']}.exr", set())["colour"] * np.float32(e)
        assert row["psnr_input"] == pytest.approx(psnr(noisy, ref), abs=1e-4)
        assert row["ssim_input"] == pytest.approx(ssim(noisy, ref), abs=1e-5)
        assert row["flip_input"] == pytest.approx(flip(noisy, ref), abs=1e-5)
        # the noisy method's output is its input: one exposure for both
        assert row["psnr_output"] == pytest.approx(row["psnr_input"], abs=1e-4)
        assert 10 < row["psnr_input"] < 40
    assert scores["mean"]["psnr_input"] == pytest.approx(np.mean([r["psnr_input"] for r in scores["frames"]]))
    out = capsys.readouterr().out
    assert "frame cbox_0001: input PSNR" in out and "-> output PSNR" in out and "mean of 2 frame(s)" in out
    assert json.loads((tmp_path / "out" / "denoise.json").read_text())["scores"]["mean"] == scores["mean"]


def test_a_denoiser_scores_above_its_input_and_a_resumed_run_scores_every_frame(sequence, tmp_path):
    """An untrained U-Net is no denoiser, so scored against its own output as the reference: the output's
    PSNR is the cap, the input's is not; a rerun that writes nothing still scores both frames."""
    unet = untrained_bundle(tmp_path, "unet", "+experiment=unet", "capacity=cpu")
    first = run([str(sequence), "-o", str(tmp_path / "out"), "--checkpoint", str(unet), "--no-progress"])
    refs = tmp_path / "refs"
    refs.mkdir()
    for f in ("cbox_0000", "cbox_0001"):
        shutil.copy(tmp_path / "out" / f"{f}.exr", refs / f"{f}.exr")
    report = run([str(sequence), "-o", str(tmp_path / "out2"), "--checkpoint", str(unet), "--reference",
                  str(refs), "--no-progress"])
    for row in report["scores"]["frames"]:
        assert row["psnr_output"] > 60 > row["psnr_input"]
        assert row["flip_output"] < 1e-3 < row["flip_input"]
    again = run([str(sequence), "-o", str(tmp_path / "out2"), "--checkpoint", str(unet), "--reference",
                 str(refs), "--no-progress"])
    assert again["resumed"] == ["cbox_0000", "cbox_0001"]
    assert [r["psnr_output"] for r in again["scores"]["frames"]] == \
        pytest.approx([r["psnr_output"] for r in report["scores"]["frames"]], abs=1e-3)
    assert len(first["scores"]["frames"]) == 2    # reference/ beside the frames


def test_missing_references_are_named_or_leave_the_run_unscored(sequence, tmp_path, capsys):
    refs = tmp_path / "refs"
    refs.mkdir()
    shutil.copy(sequence / "reference" / "cbox_0000.exr", refs / "cbox_0000.exr")
    with pytest.raises(SystemExit):
        run([str(sequence), "-o", str(tmp_path / "out"), "--experiment", "noisy", "--reference", str(refs),
             "--no-progress"])
    assert f"--reference {refs}: no reference for 1 of 2 frames ({refs / 'cbox_0001.exr'})" in \
        capsys.readouterr().err
    frames = tmp_path / "frames"
    shutil.copytree(sequence, frames)
    (frames / "reference" / "cbox_0001.exr").unlink()
    report = run([str(frames), "-o", str(tmp_path / "out"), "--experiment", "noisy", "--no-progress"])
    assert "scores" not in report

"""``mcd-denoise`` resumes only outputs that are as it wrote them (mcd/denoise/resume.py): a rerun kept every
frame ``denoise.json`` called finished whose EXR existed, so an emptied output and one replaced by garbage
were "3 finished before, kept". Each finished frame's files are now recorded with their SHA-256 and checked on
resume; a damaged frame is denoised again."""

from __future__ import annotations

import json
import logging
import os

from mcd.denoise.cli import run
from tests.reliability.denoise_helpers import write_frames

NOISY = ("--experiment", "noisy", "--no-progress")


def test_an_emptied_or_replaced_output_is_denoised_again_on_resume(tmp_path, caplog):
    frames, out = tmp_path / "in", tmp_path / "out"
    write_frames(frames, n=3)
    run([str(frames), "-o", str(out), *NOISY])
    good = {n: (out / n).read_bytes() for n in ("f0000.exr", "f0001.exr", "f0002.png")}
    untouched = os.stat(out / "f0002.exr").st_mtime_ns
    (out / "f0000.exr").write_bytes(b"")                      # emptied
    (out / "f0001.exr").write_bytes(os.urandom(len(good["f0001.exr"])))  # replaced by garbage, same size
    with caplog.at_level(logging.WARNING, logger="mcd.denoise.resume"):
        report = run([str(frames), "-o", str(out), *NOISY])
    assert report["resumed"] == ["f0002"]
    assert (out / "f0000.exr").read_bytes() == good["f0000.exr"]
    assert (out / "f0001.exr").read_bytes() == good["f0001.exr"]
    assert os.stat(out / "f0002.exr").st_mtime_ns == untouched
    assert f"{out / 'f0000.exr'}: not as the previous run wrote it" in caplog.text
    record = json.loads((out / "denoise.json").read_text())
    assert record["complete"] and record["finished"] == ["f0000", "f0001", "f0002"]
    assert set(record["checksums"]["f0002"]) == {"f0002.exr", "f0002.png"}

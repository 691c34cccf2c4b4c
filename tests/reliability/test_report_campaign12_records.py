"""Campaign 12, part 2 (notes/reliability_campaigns.md): run records that ``mcd.report`` left out without a
word. A ``frames.csv`` holding its header only (every run tests at least one frame) kept its run out of
``per_frame.csv`` and the per-frame plots, exit 0; a sample EXR that is a link to ``/dev/zero`` (or a FIFO)
was not read, rightly, but left out of the strips and the viewer unnamed, where a damaged regular file is
named and the command exits 1 (``reliability/test_report_damaged_samples.py``)."""

from __future__ import annotations

import os

from mcd.reporting.runs import FRAMES_COLUMNS, Run, frames_problem
from mcd.reporting.strips import UNREADABLE, samples


def test_a_frames_csv_holding_its_header_only_is_named_as_corrupt(tmp_path):
    path = tmp_path / "frames.csv"
    path.write_text(",".join(FRAMES_COLUMNS) + "\n")
    problem = frames_problem(path)
    assert problem is not None and str(path) in problem and "header only" in problem
    path.write_text(",".join(FRAMES_COLUMNS) + "\ncbox,0,20.5\n")
    assert frames_problem(path) is None


def test_a_sample_that_is_no_regular_file_is_named_not_dropped(tmp_path):
    scene = tmp_path / "run" / "samples" / "cbox"
    scene.mkdir(parents=True)
    (scene / "0000_output.exr").symlink_to("/dev/zero")
    os.mkfifo(scene / "0000_noisy.exr")
    UNREADABLE.clear()
    try:
        assert samples(Run(path=tmp_path / "run")) == {}
        named = {str(p) for p in UNREADABLE}
        assert named == {str(scene / "0000_output.exr"), str(scene / "0000_noisy.exr")}
        assert all("not a regular file" in why for why in UNREADABLE.values())
    finally:
        UNREADABLE.clear()

"""Campaign 12, part 2 (notes/reliability_campaigns.md): run records that ``mcd.report`` left out without a
word. A ``frames.csv`` holding its header only (every run tests at least one frame) kept its run out of
``per_frame.csv`` and the per-frame plots, exit 0; a sample EXR that is a link to ``/dev/zero`` (or a FIFO)
was not read, rightly, but left out of the strips and the viewer unnamed, where a damaged regular file is
named and the command exits 1 (``reliability/test_report_damaged_samples.py``). A ``frames.csv`` frame of -5
went into ``per_frame.csv``; ``--current ../../x`` was taken as the current report's folder, outside
``--out``."""

from __future__ import annotations

import os

import pytest

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


def test_a_frames_csv_with_a_negative_frame_is_named_as_corrupt(tmp_path):
    path = tmp_path / "frames.csv"
    path.write_text("scene,frame,psnr\ncbox,-5,20\ncbox,1,21\n")   # went into per_frame.csv as frame -5
    problem = frames_problem(path)
    assert problem is not None and "negative frame" in problem


def test_a_current_report_name_leaving_the_output_root_is_refused(tmp_path, capsys):
    from mcd.report import main

    readme = tmp_path / "README.md"
    readme.write_text("mine\n")
    with pytest.raises(SystemExit) as exc:  # read <out>/../../x into README.md's results before
        main(["--index", "--out", str(tmp_path / "reports"), "--current", "../../x", "--readme", str(readme)])
    assert "--current='../../x': not a plain folder name" in str(exc.value.code)
    assert readme.read_text() == "mine\n" and not (tmp_path / "reports").exists()


def test_findings_between_runs_of_two_commits_say_so(tmp_path):
    from mcd.report import mixed_commits_note

    a = Run(path=tmp_path / "A_spp4", metrics={"commit": "0a34d995d4b1df64", "dirty": False})
    f = Run(path=tmp_path / "F_spp4", metrics={"commit": "1111111111111111", "dirty": True})
    assert mixed_commits_note([a, Run(path=tmp_path / "F2", metrics={"commit": "0a34d995d4b1df64"})]) is None
    note = mixed_commits_note([a, f])   # "F 4.94 dB above U-Net" was stated without it
    assert note is not None and "0a34d995d4: A_spp4" in note and "1111111111+dirty: F_spp4" in note

"""``mcd-denoise -o`` into a folder holding a user's own files named like its outputs (``f0000.png``,
``f0001.exr``) overwrote them without a word. A folder without ``denoise.json`` (no ``mcd-denoise`` run wrote
there) holding such a file is now refused before any work, naming it, and every file stays as it was
(mcd/denoise/output_folder.py ``check_unrecorded``); a run writes a first ``denoise.json`` before its first
output (``claim``), so a run stopped mid-way still resumes (docs/reliability.md, "Campaign fixes")."""

from __future__ import annotations

import json
import shutil

from mcd.denoise.cli import run
from tests.reliability.denoise_helpers import refused, snapshot, write_frames


def test_a_users_files_named_like_outputs_are_refused_and_kept(tmp_path, capsys):
    frames = write_frames(tmp_path / "in", n=3, size=(16, 24), seed=7)
    out = tmp_path / "mine"
    out.mkdir()
    (out / "f0000.png").write_text("my notes")
    shutil.copy(frames[1], out / "f0001.exr")
    (out / "other.txt").write_text("keep")
    before = snapshot(out)
    err = refused(capsys, str(tmp_path / "in"), "-o", str(out), "--checkpoint", "unet-cpu-small")
    assert f"-o {out}: holds f0000.png, f0001.exr, named like outputs of this run, and no denoise.json" in err
    assert snapshot(out) == before


def test_a_run_stopped_before_its_first_frame_finished_is_resumed(tmp_path):
    write_frames(tmp_path / "in", n=2, size=(16, 24), seed=8)
    out = tmp_path / "out"
    argv = [str(tmp_path / "in"), "-o", str(out), "--checkpoint", "unet-cpu-small", "--no-progress"]
    run(argv)
    assert json.loads((out / "denoise.json").read_text())["complete"] is True
    # as a run killed while writing frame 0 leaves the folder: its first record, one output of frame 0
    for f in out.iterdir():
        if f.name not in ("f0000.exr",):
            f.unlink()
    (out / "denoise.json").write_text(json.dumps({"complete": False}))
    again = run(argv)
    assert again["resumed"] == []
    assert {"f0000.exr", "f0001.exr", "f0001.png"} <= {f.name for f in out.iterdir()}

"""``mcd-denoise`` never loses a user's files: the output folder is checked against the inputs and for
writability before any work, outputs are written atomically and never through a symlink, and a rerun resumes
(docs/reliability.md, "Denoising your frames"; mcd/denoise/output_folder.py, output.py, resume.py)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

from mcd.denoise.cli import run
from tests.reliability.denoise_helpers import refused, snapshot, write_frames

NOISY = ("--experiment", "noisy")


@pytest.fixture
def frames(tmp_path) -> Path:
    folder = tmp_path / "in"
    paths = write_frames(folder, n=2)
    # a sibling layer file is an input too
    (folder / "f0000.albedo.exr").write_bytes(paths[0].read_bytes())
    return folder


@pytest.mark.parametrize("where", ["same", "symlink", "parent", "input_link_into_out"])
def test_an_output_folder_over_the_inputs_is_refused_and_the_inputs_are_untouched(tmp_path, capsys, frames,
                                                                                where):
    if where == "same":
        out = frames
    elif where == "symlink":
        out = tmp_path / "link"
        out.symlink_to(frames, target_is_directory=True)
    elif where == "parent":
        out = tmp_path
    else:   # the frame given is a symlink to a file inside -o
        out = tmp_path / "out"
        out.mkdir()
        (out / "f0000.exr").write_bytes((frames / "f0000.exr").read_bytes())
        (frames / "f0001.exr").unlink()
        (frames / "f0001.exr").symlink_to(out / "f0000.exr")
    before = snapshot(tmp_path)
    err = refused(capsys, str(frames), "-o", str(out), *NOISY)
    assert f"-o {out}: " in err and ("is the folder of the input" in err or "contains the input" in err)
    assert snapshot(tmp_path) == before          # every byte of every input, and nothing new


def test_an_output_folder_inside_an_input_folder_is_allowed(tmp_path, frames):
    before = snapshot(frames)
    report = run([str(frames), "-o", str(frames / "denoised"), *NOISY, "--no-progress"])
    assert report["frames"] == 2
    after = snapshot(frames)
    assert {k: v for k, v in after.items() if not k.startswith("denoised")} == before


@pytest.mark.parametrize("name", ["f0000.png", "f0001.exr", "denoise.json"])
def test_a_symlink_named_like_an_output_is_refused_and_its_target_untouched(tmp_path, capsys, frames, name):
    out = tmp_path / "out"
    out.mkdir()
    victim = tmp_path / "precious.txt"
    victim.write_text("keep me")
    (out / name).symlink_to(victim)
    err = refused(capsys, str(frames), "-o", str(out), *NOISY)
    assert f"{out / name}: a symlink named like an output" in err
    assert victim.read_text() == "keep me"
    assert sorted(p.name for p in out.iterdir()) == [name]


@pytest.mark.parametrize("kind", ["file", "below_a_file"])
def test_an_unwritable_output_is_named_before_any_work(tmp_path, capsys, frames, kind):
    afile = tmp_path / "afile"
    afile.write_text("not a folder")
    out = afile if kind == "file" else afile / "out"
    err = refused(capsys, str(frames), "-o", str(out), *NOISY)
    assert f"-o {out}: " in err
    assert ("is a file, not a folder" in err) if kind == "file" else (f"{afile} is a file" in err)
    assert afile.read_text() == "not a folder"


def _interrupt_after(monkeypatch, frames_written: int) -> None:
    """Make the PNG writer that mcd.denoise.output imports (matplotlib's ``imsave``, on first use) fail
    half-way through frame ``frames_written`` (a kill mid-write: half the bytes are on disk when it stops)."""
    import matplotlib.image as output

    real = output.imsave
    calls = {"n": 0}

    def imsave(path, img, **kw):
        calls["n"] += 1
        if calls["n"] > frames_written:
            Path(path).write_bytes(b"\x89PNG half")
            raise KeyboardInterrupt("killed while writing")
        real(path, img, **kw)

    monkeypatch.setattr(output, "imsave", imsave)


def test_an_interrupted_run_leaves_no_half_file_and_a_rerun_resumes(tmp_path, frames, monkeypatch):
    write_frames(frames, n=4, seed=1)                      # f0000..f0003
    out = tmp_path / "out"
    _interrupt_after(monkeypatch, frames_written=2)
    with pytest.raises(KeyboardInterrupt):
        run([str(frames), "-o", str(out), *NOISY, "--no-progress"])
    monkeypatch.undo()
    names = sorted(p.name for p in out.iterdir())
    assert names == ["denoise.json", "f0000.exr", "f0000.png", "f0001.exr", "f0001.png", "f0002.exr"]
    record = json.loads((out / "denoise.json").read_text())
    assert record["finished"] == ["f0000", "f0001"] and record["complete"] is False
    kept = {n: os.stat(out / n).st_mtime_ns for n in ("f0000.exr", "f0001.png")}

    report = run([str(frames), "-o", str(out), *NOISY, "--no-progress"])
    assert report["resumed"] == ["f0000", "f0001"]
    assert {n: os.stat(out / n).st_mtime_ns for n in kept} == kept          # not written again
    record = json.loads((out / "denoise.json").read_text())
    assert record["finished"] == ["f0000", "f0001", "f0002", "f0003"] and record["complete"] is True
    assert not [p for p in out.iterdir() if p.name.startswith(".")]           # no temporary file left


def test_a_rerun_with_other_settings_or_changed_inputs_denoises_every_frame_again(tmp_path, frames):
    out = tmp_path / "out"
    run([str(frames), "-o", str(out), *NOISY, "--no-progress"])
    assert run([str(frames), "-o", str(out), *NOISY, "--no-progress"])["resumed"] == ["f0000", "f0001"]
    assert run([str(frames), "-o", str(out), *NOISY, "--overlap", "8", "--no-progress"])["resumed"] == []
    write_frames(frames, n=1, seed=5)                      # f0000 is another image now
    report = run([str(frames), "-o", str(out), *NOISY, "--overlap", "8", "--no-progress"])
    assert report["resumed"] == []
    from mcd.data.exr import read_exr
    from mcd.denoise.frames import read_channels

    chans = read_channels(frames / "f0000.exr")
    assert np.allclose(read_exr(out / "f0000.exr"), np.stack([chans[c] for c in "RGB"], -1), rtol=1e-5)


def test_the_references_folder_is_an_input_too(tmp_path, capsys, frames):
    (frames / "reference").mkdir()
    for name in ("f0000.exr", "f0001.exr"):
        (frames / "reference" / name).write_bytes((frames / name).read_bytes())
    before = snapshot(tmp_path)
    refs = frames / "reference"
    err = refused(capsys, str(frames), "-o", str(refs), *NOISY)
    assert f"-o {refs}: is the folder of the input {refs / 'f0000.exr'}" in err
    assert snapshot(tmp_path) == before

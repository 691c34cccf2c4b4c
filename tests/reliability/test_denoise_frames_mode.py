"""``mcd-denoise`` on frames from disk. Defect 27: a complete frame named
``x.albedo.exr`` (read as a sibling layer file of an ``x.exr`` that is not there) was dropped from the
sequence without a log line. Defect 28: ``--exposure`` was silently ignored. ``mcd-denoise`` runs for real
on real EXR files."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.conftest import command_in_worker
from tests.reliability.denoise_helpers import write_frames


def _denoise(*argv: str) -> subprocess.CompletedProcess:
    return command_in_worker("mcd.denoise", [*argv, "--no-progress"], Path.cwd(), {"OMP_NUM_THREADS": "1"})


@pytest.mark.slow
def test_defect27_a_frame_named_like_a_layer_without_its_frame_is_named_in_the_log(tmp_path):
    frames = write_frames(tmp_path / "in", n=3)
    shutil.move(frames[2], tmp_path / "in" / "x.albedo.exr")  # a complete frame, every layer inside
    shutil.copy(frames[0], tmp_path / "in" / "f0000.albedo.exr")  # a sibling layer file of f0000.exr
    proc = _denoise(str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--experiment", "noisy")
    assert proc.returncode == 0, proc.stderr[-3000:]
    orphan = tmp_path / "in" / "x.albedo.exr"
    assert (f"{orphan}: named as a sibling layer file (<stem>.albedo.exr) of x.exr, which is not there: not "
            "denoised; rename it") in proc.stderr
    assert "f0000.albedo.exr: named as" not in proc.stderr  # its frame is there: a layer, as documented
    assert sorted(p.name for p in (tmp_path / "out").glob("*.exr")) == ["f0000.exr", "f0001.exr"]


@pytest.mark.slow
def test_defect28_exposure_is_honoured_in_frames_mode(tmp_path):
    """``--exposure`` was silently ignored on frames from disk: the network and the scores read frame 0's
    exposure. It is now the one exposure of both, recorded, and a setting that resuming compares."""
    frames = write_frames(tmp_path / "in", n=2)
    refs = tmp_path / "refs"
    refs.mkdir()
    for f in frames:
        shutil.copy(f, refs / f.name)
    common = [str(tmp_path / "in"), "--experiment", "noisy", "--reference", str(refs)]
    auto = _denoise(*common, "-o", str(tmp_path / "auto"))
    given = _denoise(*common, "-o", str(tmp_path / "given"), "--exposure", "3.5")
    assert auto.returncode == 0 and given.returncode == 0, given.stderr[-3000:]
    rec_auto = json.loads((tmp_path / "auto" / "denoise.json").read_text())
    rec = json.loads((tmp_path / "given" / "denoise.json").read_text())
    assert rec_auto["exposure"] != 3.5
    assert rec["exposure"] == 3.5 and rec["scores"]["exposure"] == 3.5 and rec["settings"]["exposure"] == 3.5
    assert "exposure x3.5 for every frame and score (--exposure)" in given.stderr
    assert "exposure x3.5 for all" in given.stdout
    again = _denoise(*common, "-o", str(tmp_path / "given"))  # another exposure: every frame again
    assert "made with other settings (exposure)" in again.stderr

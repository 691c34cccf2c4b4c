"""Defects 27 and 28 of issue 48: ``mcd-denoise`` on frames from disk. Defect 27: a complete frame named
``x.albedo.exr`` (read as a sibling layer file of an ``x.exr`` that is not there) was dropped from the
sequence without a log line. ``mcd-denoise`` runs for real on real EXR files."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys

from tests.denoise.helpers import REPO
from tests.reliability.denoise_helpers import write_frames


def _denoise(*argv: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-m", "mcd.denoise", *argv, "--no-progress"], env=env,
                          capture_output=True, text=True, timeout=300)


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

"""Campaign 8 (docs/reliability.md, "Campaign 8, part 2"): ``mcd-denoise`` reads only regular files as
frames. A FIFO named like a frame in the input folder (or given by name) was read, and the command waited
on it for ever; it is now refused before any work, exit 2, naming it, and ``-o`` is not made."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tests.conftest import module_env
from tests.reliability.denoise_helpers import write_frames


@pytest.mark.slow
@pytest.mark.parametrize("given", ["folder", "file"])
def test_a_fifo_named_like_a_frame_is_refused_instead_of_waited_on(tmp_path, given):
    frames = tmp_path / "in"
    write_frames(frames, n=2)
    os.mkfifo(frames / "f0002.exr")
    inputs = [str(frames)] if given == "folder" else [str(frames / "f0000.exr"), str(frames / "f0002.exr")]
    proc = subprocess.run([sys.executable, "-m", "mcd.denoise", *inputs, "-o", str(tmp_path / "out"),
                           "--experiment", "noisy", "--no-progress"], env=module_env(), capture_output=True,
                          text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert (f"{frames / 'f0002.exr'}: not a regular file (a FIFO, a device or a folder named like a frame)"
            in proc.stderr), proc.stderr
    assert not (tmp_path / "out").exists()

"""``mcd-denoise`` onto a disk without room (``mcd.denoise.output_folder.check_space``, the ENOSPC line of
``mcd.denoise.cli``; docs/reliability.md, "Campaign fixes"): onto a 24 KB tmpfs the run denoised frame 0, then
died on an OSError traceback. Now a disk that cannot hold the outputs every method writes is refused before
any work, and a disk that fills all the same ends in one error line that says the finished frames are kept
and that the same command resumes. Each in a tmpfs of a private mount namespace (``unshare -rm``)."""

from __future__ import annotations

import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from tests.reliability.denoise_helpers import write_frames

ROOT = Path(__file__).resolve().parents[2]
#: The disk says it has room, and fills during the work.
ROOMY = ("import shutil, sys; from collections import namedtuple; "
         "shutil.disk_usage = lambda p: namedtuple('U', 'total used free')(1 << 40, 0, 1 << 40); "
         "from mcd.denoise.cli import main; main(sys.argv[1:])")


def _in_tmpfs(folder: Path, argv: list[str]) -> subprocess.CompletedProcess:
    q = shlex.quote(str(folder))
    script = (f"mount -t tmpfs -o size=24k tmpfs {q} && {shlex.join(argv)}; "
              f"code=$?; ls -A {q}; cat {q}/denoise.json; exit $code")
    return subprocess.run(["unshare", "-rm", "sh", "-c", script], capture_output=True, text=True, timeout=600,
                          env={**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"})


@pytest.mark.slow
def test_a_disk_without_room_is_refused_before_and_a_full_one_is_one_line(tmp_path):
    if subprocess.run(["unshare", "-rm", "true"], capture_output=True).returncode != 0:
        pytest.skip("no unprivileged mount namespace here (unshare -rm) to mount a small tmpfs")
    write_frames(tmp_path / "in", n=3, size=(24, 32))
    out = tmp_path / "out"
    out.mkdir()
    args = [str(tmp_path / "in"), "-o", str(out), "--checkpoint", "unet-cpu-small", "--no-progress"]

    before = _in_tmpfs(out, [sys.executable, "-m", "mcd.denoise", *args])
    assert before.returncode == 2, before.stderr[-3000:]
    assert f"-o {out}: the 6 output file(s) still to write need up to" in before.stderr
    assert "Traceback" not in before.stderr and before.stdout.split() == []  # nothing written

    full = _in_tmpfs(out, [sys.executable, "-c", ROOMY, *args])
    assert full.returncode == 1, full.stderr[-3000:]
    assert "No space left on device; the frames finished before are kept in -o" in full.stderr
    assert "it resumes" in full.stderr and "Traceback" not in full.stderr
    listed, record = full.stdout.split("{", 1)
    assert "denoise.json" in listed.split() and not any(".tmp" in n for n in listed.split())
    assert json.loads("{" + record)["complete"] is False

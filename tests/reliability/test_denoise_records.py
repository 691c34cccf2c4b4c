"""Two damaged inputs of ``mcd-denoise``. Defect 25: a rerun into a folder whose ``denoise.json``
has a ``settings`` that is a list gave an AttributeError traceback. A damaged record is refused before any
frame is denoised, naming the file and the fix, and the outputs stay as they were. Defect 26:
``--checkpoint /dev/zero`` or a FIFO was reported as "no such file or folder"; it is named as not a regular
file. ``mcd-denoise`` runs for real."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys

import pytest

from tests.conftest import command_in_worker
from tests.denoise.helpers import REPO
from tests.reliability.denoise_helpers import snapshot, write_frames


def _denoise(frames, out):
    """In the worker (the FIFO and ``/dev/zero`` checks below keep a process: a regression would wait)."""
    return command_in_worker("mcd.denoise", [str(frames), "-o", str(out), "--experiment", "noisy",
                                             "--no-progress"], REPO, {"OMP_NUM_THREADS": "1"})


@pytest.fixture(scope="module")
def denoised(tmp_path_factory):
    """``(frames, out)``: two frames and what a finished ``mcd-denoise`` run of them wrote; each test damages
    its own copy of ``out``."""
    folder = tmp_path_factory.mktemp("denoised")
    write_frames(folder / "in", n=2)
    assert _denoise(folder / "in", folder / "out").returncode == 0
    return folder / "in", folder / "out"


@pytest.mark.parametrize(("damage", "why"), [
    ("settings_a_list", "settings is a JSON list, not dict"),
    ("finished_an_object", "finished is a JSON dict, not list"),
    ("a_list", "a JSON list, not an object"),
    ("truncated", "not readable JSON: JSONDecodeError"),
])
@pytest.mark.slow
def test_defect25_a_damaged_denoise_json_is_named_with_its_fix(denoised, tmp_path, damage, why):
    frames, finished = denoised
    out = tmp_path / "out"
    shutil.copytree(finished, out)
    record = out / "denoise.json"
    data = json.loads(record.read_text())
    text = {"settings_a_list": json.dumps({**data, "settings": [1, 2]}),
            "finished_an_object": json.dumps({**data, "finished": {"f0000": 1}}),
            "a_list": "[1, 2]", "truncated": record.read_text()[:40]}[damage]
    record.write_text(text)
    before = snapshot(out)
    proc = _denoise(frames, out)
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr, proc.stderr
    assert (f"mcd-denoise: error: {record}: not a record of mcd-denoise ({why}); delete it to denoise every "
            "frame again, or give another -o") in proc.stderr
    assert snapshot(out) == before


@pytest.mark.parametrize("kind", ["dev_zero", "fifo"])
@pytest.mark.slow
def test_defect26_a_checkpoint_that_is_not_a_regular_file_is_named_so(tmp_path, kind):
    write_frames(tmp_path / "in", n=1)
    if kind == "fifo":
        given = tmp_path / "weights.ckpt"
        os.mkfifo(given)
    else:
        given = "/dev/zero"
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
    proc = subprocess.run([sys.executable, "-m", "mcd.denoise", str(tmp_path / "in"), "-o",
                           str(tmp_path / "out"), "--checkpoint", str(given), "--no-progress"], env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr and "no such file" not in proc.stderr, proc.stderr
    assert (f"mcd-denoise: error: --checkpoint={given}: not a regular file or a folder (a device, FIFO or "
            "socket)") in proc.stderr

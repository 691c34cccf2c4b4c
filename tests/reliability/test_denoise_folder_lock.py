"""Two ``mcd-denoise`` runs never share an output folder (mcd/denoise/output_folder.py ``hold``): a run of 40
frames and one of 16 into one ``-o`` both exited 0, frames 0-15 were the second run's while ``denoise.json``
named the first and said complete. The folder is now locked from its check to the last write; a second run
is refused at once (exit 2), naming ``-o``, and writes nothing."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mcd.denoise.cli import run
from tests.reliability.denoise_helpers import snapshot, write_frames

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_a_second_run_into_a_folder_in_use_is_refused_and_the_first_finishes_alone(tmp_path, capsys):
    many, few, out = tmp_path / "many", tmp_path / "few", tmp_path / "out"
    write_frames(many, n=40, size=(256, 256), seed=1)
    write_frames(few, n=16, size=(256, 256), seed=2)
    env = {**os.environ, "OMP_NUM_THREADS": "1", "PYTHONPATH": str(REPO)}
    first = subprocess.Popen([sys.executable, "-m", "mcd.denoise", str(many), "-o", str(out), "--checkpoint",
                              "unet-cpu-small", "--no-progress"], env=env, cwd=REPO,
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and first.poll() is None and not (out / "f0001.exr").exists():
        time.sleep(0.02)
    assert first.poll() is None, "the first run ended before the second could start: " + first.stderr.read()
    before = snapshot(out)
    with pytest.raises(SystemExit) as stop:
        run([str(few), "-o", str(out), "--experiment", "noisy", "--no-progress"])
    still_running = first.poll() is None
    assert stop.value.code == 2
    assert (f"-o {out}: another mcd-denoise is writing into this folder; wait for it to finish, or give "
            "another folder") in capsys.readouterr().err
    assert still_running
    written = snapshot(out)
    assert all(written[name] == data for name, data in before.items()  # the second run wrote none of them
               if name != "denoise.json" and not name.startswith("."))
    _, err = first.communicate(timeout=600)
    assert first.returncode == 0, err[-4000:]
    record = json.loads((out / "denoise.json").read_text())
    assert record["complete"] and record["frames"] == 40
    assert record["finished"] == [f"f{i:04d}" for i in range(40)]
    assert sorted(p.name for p in out.glob("*.exr")) == [f"f{i:04d}.exr" for i in range(40)]


def test_the_folder_is_free_again_after_a_run(tmp_path):
    frames, out = tmp_path / "in", tmp_path / "out"
    write_frames(frames, n=2)
    run([str(frames), "-o", str(out), "--experiment", "noisy", "--no-progress"])
    report = run([str(frames), "-o", str(out), "--experiment", "noisy", "--no-progress"])
    assert report["resumed"] == ["f0000", "f0001"]

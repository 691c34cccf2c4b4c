"""Campaign 9, part 2 (notes/reliability_campaigns.md): ``python -m mcd.bench`` whose ``--out`` cannot take
the table. ``--out`` naming a folder let ``speed``, ``train`` and ``profile`` measure, then end in an
IsADirectoryError traceback (minutes of measurement at their defaults); ``speed --out <folder>/README.md``
wrote the CSV there and then its README over it, exit 0. Now each mode's parser refuses them (exit 2 naming
``--out``, ``mcd.core.paths.writable_file_to_be``) before anything is measured, and nothing is written. The
command runs for real."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import module_env

QUICK = {
    "speed": ["--methods", "noisy", "--sizes", "8x8", "--devices", "cpu", "--reps", "1", "--warmup", "0",
              "--synthetic", "capacity=cpu"],
    "train": ["--profiles", "tiny", "--methods", "unet", "--paths", "fp32", "--steps", "1", "--warmup", "0",
              "nosuch.key=1"],
    "profile": ["--method", "A", "--size", "16x16", "--synthetic", "--warmup", "0", "--repeat", "1",
                "--dtype", "fp32", "capacity=cpu"],
}


def _bench(tmp_path, mode: str, out) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mcd.bench", mode, "--out", str(out), *QUICK[mode],
                           f"paths.data_dir={tmp_path / 'data'}"], cwd=tmp_path, env=module_env(),
                          capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("mode", ["speed", "train", "profile"])
@pytest.mark.slow
def test_an_out_that_is_a_folder_is_refused_before_measuring(tmp_path, mode):
    folder = tmp_path / "results"
    folder.mkdir()
    proc = _bench(tmp_path, mode, folder)
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert f"--out={folder} is a folder, not a file" in proc.stderr and "Traceback" not in proc.stderr
    assert list(folder.iterdir()) == []


@pytest.mark.slow
def test_speed_out_named_readme_is_refused(tmp_path):
    proc = _bench(tmp_path, "speed", tmp_path / "r" / "README.md")
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert "the bench writes its README.md beside the CSV, which would replace the CSV" in proc.stderr
    assert not (tmp_path / "r").exists()

"""Campaign 10, part 1 (docs/reliability.md, "Campaign fixes"): ``python -m mcd.bench loader --dir D``
reused at another frame size. Campaign 9 left it: the synthetic EXR store was written again at the new size,
then the pack into ``D/train_float32`` (packed at the old size) ended in a TrainStoreError traceback (at the
defaults after about 3 GB were written). Now the bench's own synthetic training store of another shape is
packed again, with a warning, and the figures are of the new size.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from tests.conftest import module_env

SMALL = ["--crop", "16", "--frames", "7", "--clip-len", "5", "--seconds", "0.05", "--capacity", "cpu",
         "--experiment", "unet", "--json"]


def _loader(folder, size: int) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mcd.bench", "loader", "--dir", str(folder), "--width",
                           str(size), "--height", str(size), *SMALL], env=module_env(), capture_output=True,
                          text=True, timeout=600)


@pytest.mark.slow
def test_a_dir_reused_at_another_size_is_packed_again_and_timed_at_the_new_size(tmp_path):
    first = _loader(tmp_path / "d", 48)
    assert first.returncode == 0, first.stderr[-3000:]
    again = _loader(tmp_path / "d", 32)
    assert again.returncode == 0, again.stderr[-3000:]
    assert "Traceback" not in again.stderr
    packed = tmp_path / "d" / "train_float32"
    assert f"the synthetic training store {packed} is of another shape" in again.stderr
    out = json.loads(again.stdout.strip().splitlines()[-1])
    assert (out["shape"]["width"], out["shape"]["height"]) == (32, 32)
    meta = json.loads((tmp_path / "d" / "train_float32" / "store.json").read_text())
    assert (meta["width"], meta["height"]) == (32, 32)

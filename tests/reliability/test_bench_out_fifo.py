"""Campaign 11, part 2 (notes/reliability_campaigns.md): ``python -m mcd.bench speed --out <a FIFO>``
measured, then waited for ever opening the CSV (killed after 60 s); ``train`` and ``profile`` share the parser
type. Each mode's parser now refuses an ``--out`` that exists and is not a regular file (a FIFO, a device),
exit 2 naming ``--out``, before anything is measured (``mcd.core.paths.writable_file_to_be``). The command
runs for real."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tests.conftest import module_env
from tests.reliability.test_bench_out_file import QUICK


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["speed", "train", "profile"])
def test_an_out_that_is_a_fifo_is_refused_before_measuring(tmp_path, mode):
    fifo = tmp_path / "b.csv"
    os.mkfifo(fifo)
    proc = subprocess.run([sys.executable, "-m", "mcd.bench", mode, "--out", str(fifo), *QUICK[mode],
                           f"paths.data_dir={tmp_path / 'data'}"], cwd=tmp_path, env=module_env(),
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert f"--out={fifo} is not a regular file" in proc.stderr and "Traceback" not in proc.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["b.csv"]

"""Campaign 10, part 2 (notes/reliability_campaigns.md): ``python -m mcd.bench speed --sizes 100000x100000``
and ``profile --size 100000x100000`` allocated the frame's buffers and ended in the allocator's traceback
(120 GB); a size a little smaller could be allocated and fill a shared machine's memory. ``profile
--tolerance -1`` was taken, and refuses every table. Each is refused by the parser now (exit 2, naming the
size or flag), with a side above ``mcd.core.config_rules.MAX_SIDE``, the largest frame a data profile may
have. The command runs for real."""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import module_env


@pytest.mark.parametrize(("mode", "args", "named"), [
    ("speed", ["--methods", "noisy", "--sizes", "100000x100000", "--devices", "cpu", "--synthetic"],
     "size '100000x100000': a side above 16384 pixels"),
    ("profile", ["--method", "A", "--size", "16x20000", "--synthetic", "--dtype", "fp32"],
     "size '16x20000': a side above 16384 pixels"),
    ("profile", ["--method", "A", "--size", "16x16", "--synthetic", "--dtype", "fp32", "--tolerance", "-1"],
     "--tolerance=-1.0: give a fraction of at least 0"),
])
@pytest.mark.slow
def test_a_size_or_tolerance_out_of_range_is_refused_before_measuring(tmp_path, mode, args, named):
    out = tmp_path / "bench.csv"
    proc = subprocess.run([sys.executable, "-m", "mcd.bench", mode, *args, "--out", str(out), "capacity=cpu"],
                          cwd=tmp_path, env=module_env(), capture_output=True, text=True, timeout=300)
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert named in proc.stderr and "Traceback" not in proc.stderr, proc.stderr[-3000:]
    assert not out.exists()

"""`python -m mcd.bench train` (mcd/bench/train.py): real Lightning fits on the 32x32 test store, one
process per path (each started as ``python -m mcd.bench train --child``), the CSV columns of docs/training.md
"Throughput"."""

from __future__ import annotations

import csv

import pytest

from mcd.bench import train as train_bench
from mcd.core import allocator
from tests.conftest import store32_overrides


@pytest.mark.slow
def test_train_bench_times_real_steps_per_path(cbox_store, tmp_path, capsys):
    cfg, _ = cbox_store
    out = tmp_path / "train.csv"
    overrides = [o for o in store32_overrides(cfg.paths.data_dir) if o != "data=tiny"]
    train_bench.main(["--methods", "A", "--profiles", "tiny", "--paths", "today,default", "--steps", "2",
                      "--warmup", "1", "--threads", "1", "--allocators", "system,keep", "--out", str(out),
                      *overrides])
    rows = list(csv.DictReader(out.open()))
    assert list(rows[0]) == list(train_bench.COLUMNS)
    assert [(r["method"], r["path"], r["threads"], r["allocator"]) for r in rows] == [
        ("A", "today", "1", allocator.SYSTEM),
        ("A", "today", "1", allocator.KEEP),
        ("A", "default", "1", allocator.SYSTEM),
        ("A", "default", "1", allocator.KEEP),
    ]
    for r in rows:
        assert float(r["steps_per_s"]) > 0 and float(r["steps_per_cpu_s"]) > 0 and float(r["peak_rss_mb"]) > 0
    # today runs every clip frame, the default only the two the paper's loss reads: fewer pixels per step
    today, default = rows[1], rows[3]
    pixels_per_step = {name: float(r["pixels_per_s"]) / float(r["steps_per_s"])
                       for name, r in (("today", today), ("default", default))}
    assert pixels_per_step["today"] > pixels_per_step["default"]
    assert "x today" in capsys.readouterr().out

"""``mcd.report`` timed each run's model at the run's own test size with no cap (an
8192x8192 run's U-Net held 8.7 GB in 48 s). The timed size is capped at ``MAX_TIMED_SIDE`` a side, aspect
kept, and the figure's title and the CSV say so."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest
from omegaconf import OmegaConf

from mcd.config.compose import compose
from mcd.models import latency
from mcd.reporting import speed
from mcd.reporting.runs import find_runs


@pytest.mark.slow
def test_a_huge_runs_model_is_timed_at_the_capped_size_and_the_report_says_so(tmp_path, monkeypatch):
    d = tmp_path / "A_spp4"
    (d / ".hydra").mkdir(parents=True)
    (d / ".hydra" / "config.yaml").write_text("experiment: A\nbudget: 4\nsweep_name: baselines\n")
    (d / "metrics.json").write_text(json.dumps({"psnr": 20.0, "rmse": 0.5, "experiment": "A", "budget": 4}))
    OmegaConf.save(compose(["+experiment=A", "capacity=cpu", "data.height=8192", "data.width=4096"]),
                   d / "resolved_config.yaml")
    real, asked = latency.alternated_ms, []

    def spy(timers, **kw):  # the real timing, at the size the report asks for
        for t in timers:
            height, width = t.size
            asked.append((height, width))
            assert height * width <= speed.MAX_TIMED_SIDE ** 2, f"timed at {width}x{height}: no cap"
        return real(timers, **kw)

    monkeypatch.setattr(latency, "alternated_ms", spy)
    df = speed.speed_frame(find_runs([tmp_path]))
    assert asked == [(1024, 512)]
    row = df.iloc[0]
    assert (row["height"], row["width"], row["test_size"], row["status"]) == (1024, 512, "4096x8192", "ok")
    assert row["ms_median"] > 0
    title = speed._title(df, SimpleNamespace(config_groups="cpu"))
    assert "512x1024 (its test frames; 4096x8192 timed scaled down to at most 1024 pixels a side)" in title

"""MAC counting on the meta device equals a real forward's count; the paper profile matches the paper."""

import csv

import pytest
import torch

from mcd.complexity import main
from mcd.config.methods import COMPONENTS
from mcd.models import build
from mcd.models.complexity import complexity, count_macs
from tests.models.helpers import ROWS, row_cfg


@pytest.mark.parametrize("row", ["A", "C", "F", "L"])
@pytest.mark.parametrize("size", [(40, 24), (37, 29)])
def test_meta_count_equals_real_count(row, size):
    cfg = row_cfg(row)
    with torch.device("meta"):
        meta = build(cfg)
    real = build(cfg)
    assert count_macs(meta, *size, device="meta") == count_macs(real, *size, device="cpu") > 0
    assert sum(p.numel() for p in meta.parameters()) == sum(p.numel() for p in real.parameters())


def test_counts_scale_with_pixels_for_the_uniform_row():
    """Row A is all convolutions: MACs are linear in the (padded) pixel count (without ``F_d``'s reflected
    margin, which adds a fixed border of pixels: docs/method.md "Frame edges")."""
    cfg = row_cfg("A")
    cfg.method.denoiser_margin = 0
    with torch.device("meta"):
        model = build(cfg)
    assert count_macs(model, 64, 96) == 4 * count_macs(model, 32, 48)


@pytest.mark.parametrize("row", sorted(ROWS))
def test_paper_profile_matches_the_paper_within_10_percent(row):
    params, gmacs = complexity(row_cfg(row, profile="paper"))
    paper = COMPONENTS[row]
    assert params == pytest.approx(paper["params_m"], rel=0.10)
    assert gmacs == pytest.approx(paper["gmacs"], rel=0.10)


@pytest.mark.slow
def test_command_writes_the_csv(tmp_path, capsys):
    out = tmp_path / "complexity.csv"
    main(["--experiments", "A", "F", "--out", str(out), "--height", "64", "--width", "64"])
    rows = list(csv.DictReader(out.open()))
    assert [r["name"] for r in rows] == ["A", "F"]
    assert list(rows[0]) == ["name", "params_m", "gmacs_1080p", "paper_params_m", "paper_gmacs"]
    assert float(rows[1]["paper_gmacs"]) == 478.22
    assert "F" in capsys.readouterr().out


@pytest.mark.slow
def test_command_writes_nothing_without_out(tmp_path, monkeypatch, capsys):
    """A measuring command changes no file unless asked: without ``-o`` the table is only
    printed, so a run from the repository leaves the tracked reports/complexity.csv alone."""
    monkeypatch.chdir(tmp_path)
    main(["--experiments", "A", "--height", "32", "--width", "32"])
    assert "A" in capsys.readouterr().out
    assert list(tmp_path.rglob("*")) == []

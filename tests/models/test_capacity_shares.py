"""The ``cpu`` capacity profile gives every trained method the same share of its own paper-size MACs (issue
34; docs/training.md "Capacity profiles"): counted from the built models at 1920x1080, each share within
``SHARE_BAND`` of F's."""

from __future__ import annotations

import pytest

from mcd.complexity import SHARE_BAND, main, outside_band, shares, trained_methods


@pytest.mark.slow
def test_every_trained_method_keeps_an_equal_share_of_its_paper_macs():
    rows = shares("cpu")
    assert [r["name"] for r in rows] == trained_methods()
    assert {"unet", "fastdvdnet", "rae", "dasr", "ntasad", "F"} <= set(trained_methods())
    assert outside_band(rows) == [], rows
    assert all(0.1 < r["share"] < 0.3 for r in rows), rows  # about a fifth: small enough for 2 CPU cores


@pytest.mark.slow
def test_a_share_that_leaves_the_band_is_named():
    """RAE's encoder twice as wide: its share leaves the band, and the check names it with its figures."""
    rows = shares("cpu", ("capacity.rae.encoder=[26,40,54,72,96]",))
    problems = outside_band(rows)
    assert len(problems) == 1 and problems[0].startswith("rae: ") and "x F's" in problems[0]
    rae = next(r for r in rows if r["name"] == "rae")
    assert abs(rae["ratio_to_F"] - 1) > SHARE_BAND


@pytest.mark.slow
def test_the_command_prints_the_shares_and_their_ratio_to_f(tmp_path, capsys):
    out = tmp_path / "shares.csv"
    main(["--experiments", "F", "--height", "64", "--width", "64", "--shares-out", str(out)])
    printed = capsys.readouterr().out
    assert "shares: capacity=cpu MACs / capacity=paper MACs" in printed and "outside the band" not in printed
    lines = out.read_text().splitlines()
    assert lines[0] == "name,gmacs_1080p,paper_profile_gmacs_1080p,share,ratio_to_F"
    assert len(lines) == 1 + len(trained_methods())

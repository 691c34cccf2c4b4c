"""``python tools/blur_floor.py`` (notes/dark_regions.md, "How much blur the input's FLIP allows"): the blur a
scene's noisy input allows before FLIP calls the blur worse, on a real 32x32 store, and the table written
between the markers."""

from __future__ import annotations

import numpy as np
import pytest

from mcd.core.metrics import flip
from tests.conftest import store32_overrides
from tools import blur_floor


def test_blur_keeps_a_flat_frame_and_its_edges_and_spreads_a_point():
    flat = np.full((9, 11, 3), 1e5, dtype=np.float32)  # HDR, odd size: the frame's edge is not darkened
    np.testing.assert_allclose(blur_floor.blurred(flat, 1.5), flat, rtol=1e-6)
    point = np.zeros((15, 15, 3), dtype=np.float32)
    point[7, 7] = 1.0
    b = blur_floor.blurred(point, 1.0)
    assert b[7, 7, 0] < 0.2 and b[7, 8, 0] > 0.05 and b.sum() == pytest.approx(3.0, rel=1e-4)


def test_crossing_interpolates_between_the_measured_blurs():
    sigmas = [0.5, 1.0, 2.0]
    assert blur_floor.crossing(sigmas, [0.1, 0.2, 0.4], 0.3) == pytest.approx(1.5)
    assert blur_floor.crossing(sigmas, [0.1, 0.2, 0.4], 0.05) == 0.0
    assert blur_floor.crossing(sigmas, [0.1, 0.2, 0.4], 0.5) is None


def _rows(text: str) -> dict[str, list[str]]:
    rows = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.strip("|").split("|")]
        if len(cells) > 5 and cells[1].isdigit():
            rows[cells[0]] = cells
    return rows


@pytest.mark.slow
def test_table_of_a_real_store_written_between_markers(cbox_store, tmp_path, capsys):
    _, store = cbox_store
    overrides = store32_overrides(store.root.parent)[1:]
    doc = tmp_path / "doc.md"
    doc.write_text("intro\n<!-- blur-floor -->\nold table\n<!-- /blur-floor -->\nrest\n")
    blur_floor.main(["--data", "tiny", "--sigma", "0.5", "--sigma", "1", "--sigma", "3", "--write", str(doc),
                     *overrides])
    text = doc.read_text()
    assert text.startswith("intro\n<!-- blur-floor -->\n`python tools/blur_floor.py --data tiny")
    assert "old table" not in text and text.endswith("<!-- /blur-floor -->\nrest\n")
    assert capsys.readouterr().out.strip() in text and "commit" in text
    row = _rows(text)["cbox"]
    scores = [float(c) for c in row[4:7]]
    assert scores == sorted(scores) and scores[0] > 0  # more blur, a worse FLIP
    # the input's FLIP as mcd.core.metrics scores the store's frames
    n = int(row[1])
    noisy = [store.load("cbox", f, "c4") for f in range(n)]
    ref = [store.load("cbox", f, "ref") for f in range(n)]
    assert float(row[3]) == pytest.approx(np.mean([flip(a, b) for a, b in zip(noisy, ref, strict=True)]),
                                          abs=1e-4)


def test_write_refuses_a_file_without_markers(tmp_path):
    doc = tmp_path / "doc.md"
    doc.write_text("no markers\n")
    with pytest.raises(SystemExit, match="blur-floor"):
        blur_floor.main(["--data", "tiny", "--write", str(doc), f"paths.data_dir={tmp_path / 'none'}"])
    assert doc.read_text() == "no markers\n" and not (tmp_path / "none").exists()  # refused before any render

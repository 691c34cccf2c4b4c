"""The ring-against-interior measure of ``python tools/stage_ring.py`` (notes/dark_regions.md "Where F
loses cbox's FLIP"): a bias put on a known side of the frame's ring is found there, and nowhere else."""

from __future__ import annotations

import numpy as np
import pytest

from tools.stage_ring import SIDES, ring_mask, ring_stats


def test_a_brightened_side_shows_on_that_side_only():
    rng = np.random.default_rng(0)
    ref = rng.uniform(0.05, 2.0, (20, 24, 3)).astype(np.float32)
    top = ref.copy()
    top[:3] *= 1.5                                     # the top rows, corners included
    s = ring_stats(top, ref, 3)
    assert s["top"] > 0.01
    assert s["bottom"] == s["left"] == s["right"] == 0.0
    assert s["ring_bias"] > 0.0 and s["inner_bias"] == 0.0
    assert s["ring_flip"] > 2 * s["inner_flip"] > 0.0      # FLIP's filters carry some error inwards
    same = ring_stats(ref, ref, 3)
    assert all(same[k] == 0.0 for k in ("ring_bias", "inner_bias", "flip", *SIDES))


def test_the_ring_mask_and_its_limits():
    mask = ring_mask(10, 12, 2)
    assert mask.sum() == 10 * 12 - 6 * 8
    assert not mask[2:-2, 2:-2].any()
    with pytest.raises(ValueError, match="--width 5"):
        ring_mask(10, 12, 5)

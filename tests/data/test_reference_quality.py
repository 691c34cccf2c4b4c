"""Reference quality estimate and per-scene spp (mcd/data/reference_quality.py; docs/data.md)."""

import numpy as np
import pytest

from mcd.data.reference_quality import estimate_psnr, spp_for_target
from mcd.metrics import psnr


def test_estimate_from_two_halves_matches_the_error_against_a_converged_render(cbox32):
    """Real renders: two 64-spp halves estimate the PSNR of their 128-spp mean against a 4096-spp render."""
    _, renderer = cbox32
    a, b = renderer.color(64, seed=11), renderer.color(64, seed=12)
    converged = renderer.color(4096, seed=13)
    exposure = 0.5 / float(converged.mean())  # as the store's auto exposure
    est = estimate_psnr(a, b, exposure)
    actual = psnr((a + b) / 2 * exposure, converged * exposure)
    assert est == pytest.approx(actual, abs=1.0)
    # and it tracks the spp: a quarter of the samples is ~6 dB worse
    est_low = estimate_psnr(renderer.color(16, seed=21), renderer.color(16, seed=22), exposure)
    assert est - est_low == pytest.approx(6.0, abs=1.5)


def test_estimate_edge_cases():
    black = np.zeros((8, 8, 3))
    assert estimate_psnr(black, black) == 100.0
    with pytest.raises(ValueError, match="one shape"):
        estimate_psnr(black, np.zeros((8, 9, 3)))


def test_spp_for_target_scales_with_the_noise_and_respects_the_bounds():
    assert spp_for_target(256, 34.0, 40.0, 4096) == 1024           # 256 * 10^0.6 = 1019 -> 1024
    assert spp_for_target(256, 41.0, 40.0, 4096) == 256            # already clean: the pilot's spp
    assert spp_for_target(256, 22.0, 40.0, 4096) == 4096           # capped
    assert spp_for_target(256, 39.5, 40.0, 4096, step=64) == 320   # 287 -> next multiple of 64
    with pytest.raises(ValueError):
        spp_for_target(256, 30.0, 40.0, 128)

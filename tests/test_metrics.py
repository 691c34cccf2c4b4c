"""mcd.core.metrics against known answers (docs/benchmark.md "Metrics")."""

import math

import numpy as np
import pytest
from skimage.metrics import structural_similarity

from mcd.core import metrics


def from_display(d: np.ndarray) -> np.ndarray:
    """Linear HDR whose display image is ``d`` (inverse of Reinhard + gamma)."""
    t = d**2.2
    return t / (1.0 - t)


def test_display_transform_known_values():
    x = np.array([0.0, 1.0, np.inf, -3.0, 1e4])
    d = metrics.to_display(x)
    np.testing.assert_allclose(d[:4], [0.0, 0.5 ** (1 / 2.2), 1.0, 0.0])
    assert 0.99 < d[4] <= 1.0


def test_psnr_of_known_mse():
    ref = from_display(np.full((16, 16, 3), 0.5))
    x = from_display(np.full((16, 16, 3), 0.6))  # display error 0.1 everywhere: MSE 0.01 -> 20 dB
    assert metrics.psnr(x, ref) == pytest.approx(20.0, abs=1e-6)


def test_psnr_identical_and_all_black_is_capped():
    black = np.zeros((8, 8, 3), np.float32)
    assert metrics.psnr(black, black) == metrics.PSNR_CAP_DB
    assert metrics.psnr(black + 1e-12, black) <= metrics.PSNR_CAP_DB


def test_ssim_matches_skimage_on_display_images_and_is_in_unit_range():
    rng = np.random.default_rng(0)
    ref = rng.gamma(1.0, 1.0, (32, 32, 3)).astype(np.float32)
    x = ref + rng.normal(0, 0.3, ref.shape).astype(np.float32)
    expected = structural_similarity(metrics.to_display(ref), metrics.to_display(x), data_range=1.0,
                                     channel_axis=-1)
    got = metrics.ssim(x, ref)
    assert got == pytest.approx(expected)
    assert 0.0 < got < 1.0
    assert metrics.ssim(ref, ref) == pytest.approx(1.0)


def test_ssim_refuses_images_smaller_than_its_window():
    with pytest.raises(ValueError, match="at least 7x7"):
        metrics.ssim(np.zeros((5, 9, 3)), np.zeros((5, 9, 3)))


def test_rmse_known_values_on_linear_hdr():
    ref = np.zeros((4, 4, 3))
    assert metrics.rmse(ref + 1.0, ref) == pytest.approx(1.0 / 1e-2)
    ref = np.full((4, 4, 3), 1e4)
    assert metrics.rmse(ref * 1.1, ref) == pytest.approx(1e6 / (1e8 + 1e-2))


def test_temporal_l1_known_value_and_zero_for_matching_change():
    a, b = from_display(np.full((4, 4, 3), 0.2)), from_display(np.full((4, 4, 3), 0.5))
    assert metrics.temporal_l1(b, a, b, a) == pytest.approx(0.0)
    # the output stays still while the reference changes by 0.3 in display space
    assert metrics.temporal_l1(a, a, b, a) == pytest.approx(0.3)


def test_shape_mismatch_is_an_error():
    with pytest.raises(ValueError, match="one shape"):
        metrics.psnr(np.zeros((4, 4, 3)), np.zeros((4, 5, 3)))


def test_aggregate_weighs_scenes_equally_and_skips_missing_pairs():
    rows = [{"scene": "a", "psnr": 10.0, "lt": math.nan}]
    rows += [{"scene": "b", "psnr": p, "lt": lt} for p, lt in [(20.0, math.nan), (30.0, 0.2), (40.0, 0.4)]]
    out = metrics.aggregate(rows, keys=("psnr", "lt"))
    assert out["per_scene"]["b"]["psnr"] == pytest.approx(30.0)
    assert out["psnr"] == pytest.approx(20.0)  # (10 + 30) / 2, not the frame mean 25
    assert out["lt"] == pytest.approx(0.3)  # scene a has no pair
    assert out["frames"] == {"a": 1, "b": 3}
    with pytest.raises(ValueError, match="empty"):
        metrics.aggregate([])


def test_flip_is_zero_for_identical_images_and_grows_with_the_error():
    rng = np.random.default_rng(0)
    ref = from_display(rng.uniform(0.2, 0.8, (32, 32, 3)))
    assert metrics.flip(ref, ref) == 0.0
    small = from_display(np.clip(metrics.to_display(ref) + rng.normal(0, 0.02, ref.shape), 0, 0.99))
    large = from_display(np.clip(metrics.to_display(ref) + rng.normal(0, 0.2, ref.shape), 0, 0.99))
    assert 0 < metrics.flip(small, ref) < metrics.flip(large, ref) <= 1
    err = metrics.flip_map(large, ref)
    assert err.shape == (32, 32) and float(err.mean()) == pytest.approx(metrics.flip(large, ref), rel=1e-6)


def test_flip_handles_hdr_and_black_frames():
    black = np.zeros((16, 16, 3))
    hdr = np.full((16, 16, 3), 1e5)
    assert metrics.flip(black, black) == 0.0
    assert 0.5 < metrics.flip(hdr, black) <= 1.0  # white against black: FLIP's largest errors


def test_temporal_psnr_known_value_and_cap_for_matching_change():
    ref0 = from_display(np.full((8, 8, 3), 0.3))
    ref1 = from_display(np.full((8, 8, 3), 0.5))
    assert metrics.temporal_psnr(ref1, ref0, ref1, ref0) == metrics.PSNR_CAP_DB
    x1 = from_display(np.full((8, 8, 3), 0.6))  # its change is 0.1 larger than the reference's: 20 dB
    assert metrics.temporal_psnr(x1, ref0, ref1, ref0) == pytest.approx(20.0, abs=1e-6)


def test_border_gap_is_zero_for_uniform_error_and_negative_for_a_bad_frame():
    ref = from_display(np.full((32, 32, 3), 0.5))
    x = from_display(np.full((32, 32, 3), 0.55))
    assert metrics.border_gap(x, ref) == pytest.approx(0.0, abs=1e-9)
    framed = metrics.to_display(x).copy()
    framed[:4] = framed[-4:] = framed[:, :4] = framed[:, -4:] = 0.7   # display error 0.2 on the frame
    gap = metrics.border_gap(from_display(framed), ref)
    assert gap == pytest.approx(20 * math.log10(0.05 / 0.2), abs=1e-6)  # 0.05 inside: -12.04 dB
    assert math.isnan(metrics.border_gap(x[:11, :11], ref[:11, :11]))  # no interior
    assert metrics.border_psnr(from_display(framed), ref) == pytest.approx(20 * math.log10(1 / 0.2), abs=1e-6)
    assert math.isnan(metrics.border_psnr(x[:11, :11], ref[:11, :11]))


def test_colour_shift_is_the_largest_channel_ratio_and_nan_for_a_black_channel():
    ref = np.ones((8, 8, 3))
    x = ref * np.array([1.0, 0.9, 1.02])
    assert metrics.colour_shift(x, ref) == pytest.approx(0.1)
    assert metrics.colour_shift(ref * 1e5, ref * 1e5) == pytest.approx(0.0)
    assert math.isnan(metrics.colour_shift(x, ref * np.array([1.0, 0.0, 1.0])))

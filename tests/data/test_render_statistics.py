"""Statistics of real tiny renders, on the 32x32 Cornell box.

Tolerances. With R independent realisations per pixel, the per-pixel z-score of a difference of means, ``(a -
b) / sqrt(var_a / R + var_b / R)``, is close to a t variable with 2R - 2 degrees of freedom (mean 0, variance
~1). Averaged over the P = 32 * 32 * 3 pixel-channels (correlated across the 3 channels of a pixel, so about
1000 independent values) its mean has a standard deviation of about 0.03 and the mean of ``z^2`` one of about
0.05; we accept ``|mean z| < 0.2`` and ``0.8 < mean z^2 < 1.25`` (over 4 standard deviations). The ratio of
two sample variances of R values each follows F(R-1, R-1), whose median is exactly 1 and whose log has a
standard deviation of about ``2 / sqrt(R - 1)`` = 0.3 for R = 48; the median over ~1000 pixels then has a
standard deviation near 0.012, so ``|median ratio - 1| < 0.05`` (about 4 of them) is safe, yet fails for a
render with one sample too many or too few at 12 spp (variance scales with 1/spp: 13 or 11 samples move the
ratio by 8-9%; ``test_variance_check_detects_a_wrong_sample_count`` shows it on the same realisations).
Medians and z-scores are used because path-traced noise is heavy-tailed (a plain mean of variances over 40
realisations differed by 20% in a trial run).
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mcd.data.spp_map_render import render_spp_map

R = 48


def _z(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Mean z and mean z^2 of the per-pixel difference of means of two stacks of realisations."""
    va, vb = a.var(0, ddof=1), b.var(0, ddof=1)
    keep = (va + vb) > 0
    z = (a.mean(0) - b.mean(0))[keep] / np.sqrt((va + vb)[keep] / len(a))
    return float(z.mean()), float((z**2).mean())


def _var_ratio(a: np.ndarray, b: np.ndarray) -> float:
    va, vb = a.var(0, ddof=1), b.var(0, ddof=1)
    keep = (va > 0) & (vb > 0)
    return float(np.median(va[keep] / vb[keep]))


def _neighbour_correlation(imgs: np.ndarray) -> float:
    """Correlation of standardised noise between horizontally adjacent pixels over realisations."""
    std = imgs.std(0, keepdims=True)
    e = (imgs - imgs.mean(0, keepdims=True)) / np.where(std > 0, std, np.inf)
    return float((e[:, :, 1:] * e[:, :, :-1]).mean() / (e**2).mean())


def test_box_filter_noise_is_uncorrelated_between_neighbours(cbox32):
    import mitsuba as mi

    scene, r = cbox32
    box = np.stack([r.color(4, seed=100 + s) for s in range(24)])
    corr_box = _neighbour_correlation(box)
    gauss_sensor = mi.load_dict(
        {
            "type": "perspective",
            "fov": r.fov,
            "fov_axis": "x",
            "to_world": mi.ScalarTransform4f(r.to_world.astype(np.float32)),
            "film": {"type": "hdrfilm", "width": 32, "height": 32, "rfilter": {"type": "gaussian"}},
        }
    )
    gauss = np.stack(
        [np.asarray(mi.render(scene, sensor=gauss_sensor, spp=4, seed=200 + s)) for s in range(24)]
    )
    corr_gauss = _neighbour_correlation(gauss)
    assert abs(corr_box) < 0.05, corr_box  # ~1/sqrt(24 * 32 * 31 * 3) = 0.004 by chance
    assert corr_gauss > 0.2, corr_gauss  # the control: a Gaussian filter shares samples between neighbours


def test_stack_converges_to_the_reference(cbox_store):
    _, store = cbox_store
    n = store.frame_count("cbox")
    levels = [1, 2, 4, 8, 16, 32]
    mse = []
    for k in levels:
        err = [
            np.mean((store.load("cbox", f, f"c{k}") - store.load("cbox", f, "ref")) ** 2) for f in range(n)
        ]
        mse.append(float(np.mean(err)))
    assert all(a > b for a, b in zip(mse, mse[1:], strict=False)), mse
    slope = np.polyfit(np.log(levels), np.log(mse), 1)[0]
    # MSE = s2 / k + s2 / 256 (the 256-spp reference's own noise): slope -0.95 expected, -1 without ref noise
    assert -1.1 < slope < -0.8, slope
    bias = np.array(
        [store.load("cbox", f, "c32").mean() / store.load("cbox", f, "ref").mean() - 1 for f in range(n)]
    )
    assert abs(_t(bias)) < 3.5, bias  # unbiased: the mean relative error over frames is within its noise
    assert abs(_t((1 + bias) * 1.03 - 1)) > 3.5  # the control: a 3% brighter c32 would fail


def _t(values: np.ndarray) -> float:
    """t statistic of the mean of ``values`` against 0 (its mean over its standard error)."""
    return float(values.mean() / (values.std(ddof=1) / np.sqrt(len(values))))


@pytest.fixture(scope="module")
def realisations(cbox32):
    """R independent stacks c1..c32, R direct renders at 3 and 12 spp, R true adaptive renders of a 3-map."""
    scene, r = cbox32
    stacks = np.stack(
        [[r.color(k, seed=10_000 + 10 * s + i) for i, k in enumerate([1, 2, 4, 8, 16, 32])] for s in range(R)]
    )  # [R, 6, H, W, 3]
    direct = {k: np.stack([r.color(k, seed=50_000 + 100 * k + s) for s in range(R)]) for k in (3, 12)}
    adaptive3 = np.stack(
        [render_spp_map(scene, np.full((32, 32), 3), seed=90_000 + s, sensor=r.sensor) for s in range(R)]
    )
    return stacks, direct, adaptive3


def _simulate(stacks: np.ndarray, m: np.ndarray) -> np.ndarray:
    from mcd.sampling import simulated_render

    stack = torch.from_numpy(stacks).permute(0, 1, 4, 2, 3)  # [R, 6, 3, H, W]
    mt = torch.from_numpy(np.broadcast_to(m, (len(stacks), 1, *m.shape)).copy()).float()
    return simulated_render(mt, stack).permute(0, 2, 3, 1).numpy()


@pytest.mark.slow
@pytest.mark.parametrize("k", [3, 12])
def test_simulated_constant_map_matches_direct_render(realisations, k):
    stacks, direct, _ = realisations
    sim = _simulate(stacks, np.full((32, 32), k))
    mz, mz2 = _z(sim, direct[k])
    assert abs(mz) < 0.2 and 0.8 < mz2 < 1.25, (mz, mz2)
    assert abs(_var_ratio(sim, direct[k]) - 1) < 0.05


@pytest.mark.parametrize(("asked", "given"), [(3, 4), (3, 2), (12, 11), (12, 13)])
def test_variance_check_detects_a_wrong_sample_count(realisations, asked, given):
    """One sample too many or too few changes the variance by asked / given (13 for 12: -7.7%, 11: +9.1%):
    outside the +-0.05 bound of the matching test, which is ~4 standard deviations of the median ratio."""
    stacks, direct, _ = realisations
    wrong = _simulate(stacks, np.full((32, 32), given))
    ratio = _var_ratio(wrong, direct[asked])
    assert abs(ratio - 1) > 0.05, ratio
    assert (ratio > 1) == (given < asked), ratio


def test_a_render_split_into_passes_matches_one_pass(cbox32, realisations):
    """``render.max_samples_per_pass`` below one frame's samples splits a 12 spp render into 3 passes of 4
    spp with their own seeds: the same estimator (mean and variance) as one 12 spp pass."""
    from mcd.data.renderer import SceneRenderer

    scene, r = cbox32
    split = SceneRenderer(scene, 32, 32, r.fov, max_samples_per_pass=32 * 32 * 5)
    split.set_camera(r.to_world)
    passes = np.stack([split.color(12, seed=50_000 + 100 * 12 + s) for s in range(R)])
    _, direct, _ = realisations
    assert not np.array_equal(passes[0], direct[12][0])  # same seed, yet split: other samples
    assert split.samples_rendered == R * 12 * 32 * 32
    mz, mz2 = _z(passes, direct[12])
    assert abs(mz) < 0.2 and 0.8 < mz2 < 1.25, (mz, mz2)
    assert abs(_var_ratio(passes, direct[12]) - 1) < 0.05


def test_true_adaptive_render_matches_direct_and_simulated(realisations):
    stacks, direct, adaptive3 = realisations
    mz, mz2 = _z(adaptive3, direct[3])
    assert abs(mz) < 0.2 and 0.8 < mz2 < 1.25, (mz, mz2)
    assert abs(_var_ratio(adaptive3, direct[3]) - 1) < 0.1
    sim = _simulate(stacks, np.full((32, 32), 3))
    assert abs(_var_ratio(adaptive3, sim) - 1) < 0.1


def test_true_adaptive_render_follows_a_varying_map(cbox32, realisations):
    scene, r = cbox32
    stacks, _, _ = realisations
    m = np.zeros((32, 32), np.int64)
    m[:, 16:] = 12  # right half gets 12 samples, left half none
    m[:8, 16:] = 1
    ad = np.stack([render_spp_map(scene, m, seed=70_000 + s, sensor=r.sensor) for s in range(R)])
    assert not ad[:, :, :16].any()  # zero samples: zero, not NaN
    sim = _simulate(stacks, m)
    mz, mz2 = _z(ad[:, :, 16:], sim[:, :, 16:])
    assert abs(mz) < 0.2 and 0.8 < mz2 < 1.25, (mz, mz2)
    rows_12, rows_1 = slice(8, 32), slice(0, 8)
    assert abs(_var_ratio(ad[:, rows_12, 16:], sim[:, rows_12, 16:]) - 1) < 0.15
    # the 1-sample rows against the simulated 1-sample render of the same pixels (2 samples: ratio 0.5)
    assert abs(_var_ratio(ad[:, rows_1, 16:], sim[:, rows_1, 16:]) - 1) < 0.15


def test_render_spp_map_rejects_bad_maps(cbox32):
    scene, r = cbox32
    with pytest.raises(ValueError, match="does not match"):
        render_spp_map(scene, np.ones((8, 8)), seed=0, sensor=r.sensor)
    with pytest.raises(ValueError, match="non-negative integer"):
        render_spp_map(scene, np.full((32, 32), 1.5), seed=0, sensor=r.sensor)

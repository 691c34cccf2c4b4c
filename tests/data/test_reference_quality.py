"""Reference quality estimate and per-scene spp (mcd/data/reference_quality.py; docs/data.md)."""

import numpy as np
import pytest

from mcd.core.metrics import psnr
from mcd.data.reference_quality import estimate_psnr, spp_for_target


@pytest.mark.slow
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
    bad = black.copy()
    bad[0, 0], bad[1, 1], bad[2, 2] = np.nan, np.inf, -np.inf  # sanitised to 0, as the store does at load
    assert estimate_psnr(bad, black) == 100.0
    hdr = np.full((8, 8, 3), 1e5)
    assert estimate_psnr(hdr, hdr * 1.0001) > 60
    with pytest.raises(ValueError, match="one shape"):
        estimate_psnr(black, np.zeros((8, 9, 3)))


def test_spp_for_target_scales_with_the_noise_and_respects_the_bounds():
    assert spp_for_target(256, 34.0, 40.0, 4096) == 1024           # 256 * 10^0.6 = 1019 -> 1024
    assert spp_for_target(256, 41.0, 40.0, 4096) == 256            # already clean: the pilot's spp
    assert spp_for_target(256, 22.0, 40.0, 4096) == 4096           # capped
    assert spp_for_target(256, 39.5, 40.0, 4096, step=64) == 320   # 287 -> next multiple of 64
    assert spp_for_target(16, 25.0, 10.0, 256) == 16               # no rounding up past a clean pilot
    with pytest.raises(ValueError):
        spp_for_target(256, 30.0, 40.0, 128)


def _store(tmp_path, *extra):
    from mcd.data import StoreBuilder
    from tests.conftest import compose_cfg, store32_overrides

    overrides = [o for o in store32_overrides(tmp_path) if not o.startswith("data.ref_spp")]
    return StoreBuilder.from_cfg(compose_cfg(*overrides, "data.ref_spp=16", *extra))


@pytest.mark.slow
def test_test_frames_get_the_spp_their_scene_needs_and_training_frames_keep_ref_spp(tmp_path):
    """Real 32x32 Cornell-box renders: a 16-spp pilot (~25-30 dB) asks for more samples than the 256 cap, so
    the two test frames' references are rendered at 256 spp as two halves, each with its estimate; the rest
    keep 16 spp; a second ensure renders nothing; an easy target keeps the pilot's spp."""
    store = _store(tmp_path, "data.ref_quality.target_db=40", "data.ref_quality.max_spp=256")
    report = store.ensure({"ref"}, progress=False)
    man = store.manifest("cbox")
    rq = man["ref_quality"]
    assert rq["pilot_spp"] == 16 and rq["pilot_db"] < 40 and rq["spp"] == 256
    files = man["files"]
    assert [files[f"{f:04d}/ref.exr"]["spp"] for f in range(4)] == [256, 256, 16, 16]
    est = [files[f"{f:04d}/ref.exr"]["psnr_estimate"] for f in (0, 1)]
    assert "psnr_estimate" not in files["0002/ref.exr"]
    # 16x the samples: about 12 dB above the pilot's estimate
    assert min(est) > rq["pilot_db"] + 12.04 - 2.0
    ref = report["reference"]["cbox"]
    assert ref["test_spp"] == 256 and ref["train_spp"] == 16 and ref["test_psnr_db"] == pytest.approx(
        float(np.mean(est)), abs=0.01)
    again = store.ensure({"ref"}, progress=False)
    assert again["rendered"] == {} and again["reused"] == {"ref": 12}
    lower_cap = _store(tmp_path, "data.ref_quality.target_db=40", "data.ref_quality.max_spp=128")
    assert lower_cap.ensure({"ref"}, progress=False)["rendered"] == {"ref": 2}  # the two test frames only

    easy = _store(tmp_path, "data.ref_quality.target_db=10", "data.ref_quality.max_spp=256")
    easy.ensure({"ref"}, progress=False)
    man = easy.manifest("cbox")
    assert man["ref_quality"]["spp"] == 16  # already above the target: the pilot's spp
    assert man["files"]["0000/ref.exr"]["spp"] == 16 and "psnr_estimate" in man["files"]["0000/ref.exr"]


def test_ref_quality_off_and_a_cap_below_ref_spp(tmp_path):
    store = _store(tmp_path, "data.ref_quality.target_db=null")
    store.ensure({"ref"}, progress=False)
    assert "ref_quality" not in store.manifest("cbox")
    assert store.reference_quality("cbox")["test_spp"] is None
    bad = _store(tmp_path, "data.ref_quality.max_spp=8")
    with pytest.raises(ValueError, match="data.ref_quality.max_spp=8 is below data.ref_spp=16"):
        bad.ensure({"ref"}, progress=False)

"""Campaign 9 (docs/reliability.md): a store's auto exposure follows ``data.exposure_target``.

The exposure is a scene fact of the manifest, set from frame 0's reference when that is rendered, and applied
at load; no file depends on it. A store rendered at the default target (0.5) kept its exposure for a later
``data.exposure_target=0.25`` (nothing was rendered again, and ``_fill_scales`` filled an unknown exposure
only), so a run trained and was tested on frames whose mean was 0.5 while its ``metrics.json`` named 0.25; a
scene's fixed ``exposure`` stayed too when it went back to ``auto``. Now the manifest records the target its
exposure was set for, and another one (or a fixed exposure before) sets it again from frame 0's reference,
rendering nothing (:meth:`mcd.data.store_builder.StoreBuilder._fill_scales`) but the test frames'
references, whose spp the reference-quality pilot chooses at the new exposure (campaign 10,
``test_store_pilot_exposure.py``).
"""

from __future__ import annotations

import json

import pytest

from mcd.data import StoreBuilder
from tests.conftest import compose_cfg, store32_overrides


def _manifest(store: StoreBuilder) -> dict:
    return json.loads(store.manifest_path("cbox").read_text())


def _store(data_dir, *overrides: str) -> StoreBuilder:
    return StoreBuilder.from_cfg(compose_cfg(*store32_overrides(data_dir), *overrides))


@pytest.mark.slow
def test_another_exposure_target_sets_the_exposure_again_without_rendering(own_store):
    _, store = own_store
    before = _manifest(store)
    e0 = before["exposure"]
    quarter = _store(store.data_dir, "data.exposure_target=0.25")
    quarter.ensure({"ref", "c4"}, progress=False)
    after = _manifest(quarter)
    # the reference-quality pilot runs again at the new exposure (campaign 10, test_store_pilot_exposure.py):
    # only the test frames' references are rendered again, at the spp it chooses, and frame 0's gives the
    # exposure; every other file is kept
    assert after["exposure"] == pytest.approx(e0 / 2, rel=0.01)
    assert after["ref_quality"]["spp"] != before["ref_quality"]["spp"]
    kept = {k: v for k, v in before["files"].items() if not k.endswith("/ref.exr")}
    assert {k: after["files"][k] for k in kept} == kept
    assert float(quarter.load("cbox", 0, "ref").mean()) == pytest.approx(0.25, rel=1e-4)
    back = _store(store.data_dir)
    back.ensure({"ref"}, progress=False)
    assert _manifest(back)["exposure"] == e0


@pytest.mark.slow
def test_a_fixed_exposure_gives_way_to_auto_again(own_store):
    _, store = own_store
    e0 = _manifest(store)["exposure"]
    fixed = _store(store.data_dir, "data.scenes.cbox.exposure=2.0")
    fixed.ensure({"ref"}, progress=False)
    assert _manifest(fixed)["exposure"] == 2.0
    auto = _store(store.data_dir)
    auto.ensure({"ref"}, progress=False)
    assert _manifest(auto)["exposure"] == e0


def test_a_manifest_from_before_the_key_is_reused_without_a_write(own_store):
    """Its exposure, computed again for the same target, is the same: the scene is reused by reading alone (a
    store on a read-only mount still trains), and the manifest keeps its bytes."""
    _, store = own_store
    path = store.manifest_path("cbox")
    man = _manifest(store)
    man.pop("exposure_target", None)
    path.write_text(json.dumps(man))
    text, mtime = path.read_text(), path.stat().st_mtime_ns
    again = _store(store.data_dir)
    report = again.ensure({"ref", "c4"}, progress=False)
    assert path.read_text() == text and path.stat().st_mtime_ns == mtime
    assert not report.get("rendered"), report

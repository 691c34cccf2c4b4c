"""Campaign 10, part 1 (docs/reliability.md, "Campaign fixes"): the reference-quality pilot follows the
exposure.

The pilot (:meth:`mcd.data.store_builder.StoreBuilder._pilot`) estimates frame 0's reference PSNR on display-
mapped values, so at the scene's exposure, and picks the test frames' reference spp from it. Its key left out
``data.exposure_target`` (campaign 9 left it), so a store rendered at the default target (0.5) kept its pilot
for ``data.exposure_target=0.25``: the test frames' references stayed at the spp chosen for 0.5, where a fresh
store at 0.25 chooses another. Now the pilot records its exposure and runs again under another one; the store
then equals a fresh store at the new target.
"""

from __future__ import annotations

import json

import pytest

from mcd.data import StoreBuilder
from tests.conftest import compose_cfg, store32_overrides


def _store(data_dir, *overrides: str) -> StoreBuilder:
    return StoreBuilder.from_cfg(compose_cfg(*store32_overrides(data_dir), *overrides))


def _quality(store: StoreBuilder) -> dict:
    return json.loads(store.manifest_path("cbox").read_text())["ref_quality"]


@pytest.mark.slow
def test_another_exposure_target_runs_the_pilot_again_as_a_fresh_store_does(own_store, tmp_path):
    _, store = own_store
    old = _quality(store)
    quarter = _store(store.data_dir, "data.exposure_target=0.25")
    quarter.ensure({"ref"}, progress=False)
    fresh = _store(tmp_path / "fresh", "data.exposure_target=0.25")
    fresh.ensure({"ref"}, progress=False)
    now, want = _quality(quarter), _quality(fresh)
    assert (now["pilot_db"], now["spp"]) == (want["pilot_db"], want["spp"]), (old, now, want)
    assert now["pilot_db"] != old["pilot_db"]
    assert quarter.reference_quality("cbox") == fresh.reference_quality("cbox")
    back = _store(store.data_dir)  # the default target again: the pilot of 0.5
    back.ensure({"ref"}, progress=False)
    assert (_quality(back)["pilot_db"], _quality(back)["spp"]) == (old["pilot_db"], old["spp"])

"""A store rendered again with other settings under the same ``data.name`` while a process reads it is named
as such (``mcd.data.store.StoreReader._check_not_replaced``; docs/reliability.md, "Campaign fixes"): a 32x32
run whose store was rendered again at 48x48 by ``mcd.render`` during its training failed at its test on
"truncated or corrupt EXR (19286 bytes, the manifest says 13142)", with a render command as the fix."""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from mcd.data.store import StoreReader, StoreReplacedError
from mcd.data.store_builder import StoreBuilder
from tests.conftest import compose_cfg, store32_overrides


@pytest.mark.slow
def test_a_store_rendered_again_with_other_settings_during_a_read_is_named(cbox_store, tmp_path):
    data = tmp_path / "data"
    shutil.copytree(cbox_store[1].data_dir, data)
    cfg32 = compose_cfg(*store32_overrides(data))
    reader = StoreReader.from_cfg(cfg32)
    first = reader.load("cbox", 10, "ref")
    assert first.shape == (32, 32, 3) and np.isfinite(first).all()

    # another command renders the same data.name at 48x48 (the second process's builder)
    wide = [o if o != "data.width=32" else "data.width=48" for o in store32_overrides(data)]
    StoreBuilder.from_cfg(compose_cfg(*wide)).ensure({"ref", "c4"}, progress=False)

    with pytest.raises(StoreReplacedError, match=r"rendered again with other settings \(width 32 -> 48\)"):
        reader.load("cbox", 11, "ref")
    with pytest.raises(StoreReplacedError, match="Give each setting its own data.name"):
        reader.load("cbox", 10, "ref", verify=True)

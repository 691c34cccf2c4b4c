"""A finite value that overflows when multiplied by the exposure is sanitised too."""

from __future__ import annotations

import json
import logging

import numpy as np

from mcd.data import StoreBuilder
from mcd.data.exr import read_exr, sha256, write_exr


def test_a_huge_finite_pixel_times_the_exposure_becomes_zero_with_a_warning(own_store, caplog):
    cfg, store = own_store
    path = store.path("cbox", 3, "ref")
    img = read_exr(path)
    img[5, 7, 1] = 1e38  # finite in float32; times 4.22 it is not
    write_exr(path, img, compress=False)
    man_path = store.manifest_path("cbox")
    man = json.loads(man_path.read_text())
    man["exposure"] = 4.22
    man["files"]["0003/ref.exr"].update(bytes=path.stat().st_size, sha256=sha256(path))
    man_path.write_text(json.dumps(man))
    with caplog.at_level(logging.WARNING, logger="mcd.data.store"):
        out = StoreBuilder.from_cfg(cfg).load("cbox", 3, "ref")
    assert np.isfinite(out).all() and out[5, 7, 1] == 0
    np.testing.assert_allclose(out[0, 0], img[0, 0] * np.float32(4.22), rtol=1e-6)  # the others are scaled
    assert f"{path}: 1 NaN/Inf/negative values (after scaling) replaced by 0" in caplog.text

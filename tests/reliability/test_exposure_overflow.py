"""Frame 0 holding values near float32's largest made the float32 mean overflow to
inf, the exposure 0, then silently 1. The mean is now taken in float64 over values clamped to
``EXPOSURE_CLAMP``, and the clamped values are counted and named (mcd/data/exposure.py)."""

from __future__ import annotations

import json
import logging

import numpy as np
import pytest

from mcd.data import StoreBuilder
from mcd.data.exposure import EXPOSURE_CLAMP, auto_exposure
from mcd.data.exr import read_exr, sha256, write_exr


def test_huge_values_in_frame_0_are_clamped_counted_and_named(caplog):
    frame = np.full((8, 8, 3), 0.25, dtype=np.float32)
    frame[:4] = 3e38  # half the frame: a float32 mean overflows
    with caplog.at_level(logging.WARNING, logger="mcd.data.exposure"):
        exposure = auto_exposure(frame, 0.5, "f0000.exr")
    expected = 0.5 / ((EXPOSURE_CLAMP + 0.25) / 2)
    assert exposure == pytest.approx(expected, rel=1e-9) and np.float32(exposure) > 0
    named = f"f0000.exr: 96 of 192 values above {EXPOSURE_CLAMP:g} clamped to it for the exposure"
    assert named in caplog.text


def test_an_ordinary_hdr_frame_is_not_clamped(caplog):
    frame = np.full((8, 8, 3), 1e5, dtype=np.float32)
    frame[0, 0] = 0
    with caplog.at_level(logging.WARNING, logger="mcd.data.exposure"):
        exposure = auto_exposure(frame, 0.5)
    assert exposure == pytest.approx(0.5 / (1e5 * 189 / 192), rel=1e-9) and not caplog.text


def test_the_store_sets_a_finite_exposure_from_an_overflowing_frame_0(own_store, caplog):
    cfg, store = own_store
    path = store.path("cbox", 0, "ref")
    img = read_exr(path)
    img[:16] = 3e38
    write_exr(path, img, compress=False)
    man_path = store.manifest_path("cbox")
    man = json.loads(man_path.read_text())
    man["exposure"] = None  # as for files kept from an older manifest: taken again from frame 0
    man["files"]["0000/ref.exr"].update(bytes=path.stat().st_size, sha256=sha256(path))
    man_path.write_text(json.dumps(man))
    with caplog.at_level(logging.WARNING, logger="mcd.data.exposure"):
        StoreBuilder.from_cfg(cfg).ensure({"c1"}, progress=False)
    exposure = json.loads(man_path.read_text())["exposure"]
    assert 0 < exposure < 1e-7  # not 0, and not the silent fallback of 1
    assert f"{path}: 1536 of 3072 values above" in caplog.text

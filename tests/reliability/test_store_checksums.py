"""A same-size bitflip in a store EXR was trained on silently, because every profile
had ``data.verify_checksums: false``. The default is now ``once``: each file's SHA-256 is checked on its
first load in a process (tools/checksum_cost.py measures the cost; docs/data.md)."""

from __future__ import annotations

import pytest

import mcd.data.store as store_module
from mcd.data import StoreBuilder
from mcd.data.exr import CorruptEXRError


def _flip_a_byte(path) -> None:
    data = bytearray(path.read_bytes())
    data[-20] ^= 0xFF  # inside the pixel data: same size, still a readable EXR
    path.write_bytes(bytes(data))


def test_a_same_size_bitflip_is_refused_by_default(own_store):
    cfg, store = own_store
    assert cfg.data.verify_checksums == "once"  # the profile's default
    path = store.path("cbox", 2, "c1")
    size = path.stat().st_size
    _flip_a_byte(path)
    assert path.stat().st_size == size
    with pytest.raises(CorruptEXRError, match="checksum differs from the manifest") as err:
        StoreBuilder.from_cfg(cfg).load("cbox", 2, "c1")
    assert str(path) in str(err.value) and "python -m mcd.render" in str(err.value)


def test_each_file_is_hashed_once_per_reader_unless_it_changes(own_store, monkeypatch):
    cfg, store = own_store
    hashed: list[str] = []
    real = store_module.sha256
    monkeypatch.setattr(store_module, "sha256", lambda p: hashed.append(p.name) or real(p))
    reader = StoreBuilder.from_cfg(cfg)
    for _ in range(3):
        reader.load("cbox", 1, "c1")
        reader.load("cbox", 1, "ref")
    assert sorted(hashed) == ["c1.exr", "ref.exr"]
    path = store.path("cbox", 1, "c1")
    _flip_a_byte(path)  # changed under the reader: checked again
    with pytest.raises(CorruptEXRError, match="checksum"):
        reader.load("cbox", 1, "c1")


@pytest.mark.parametrize(("value", "mode"), [("never", "never"), (False, "never"), (True, "always")])
def test_the_setting_can_turn_it_off_or_on_for_every_load(own_store, value, mode):
    cfg, store = own_store
    cfg.data.verify_checksums = value
    reader = StoreBuilder.from_cfg(cfg)
    assert reader.verify_mode == mode
    _flip_a_byte(store.path("cbox", 2, "c1"))
    if mode == "never":
        assert reader.load("cbox", 2, "c1").shape == (32, 32, 3)
    else:
        with pytest.raises(CorruptEXRError, match="checksum"):
            reader.load("cbox", 2, "c1")


def test_a_bad_setting_is_named(own_store):
    cfg, _ = own_store
    cfg.data.verify_checksums = "sometimes"
    with pytest.raises(ValueError, match=r"verify_checksums='sometimes': expected one of once, always"):
        StoreBuilder.from_cfg(cfg)

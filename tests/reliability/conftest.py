"""Fixtures of the reliability tests: a private copy of the session's rendered 32x32 Cornell-box store."""

from __future__ import annotations

import shutil

import pytest
from omegaconf import open_dict

from mcd.data import StoreBuilder


@pytest.fixture
def own_store(cbox_store, tmp_path):
    """``(cfg, store)``: a copy of ``cbox_store`` (every buffer, 12 frames) in ``tmp_path``, to damage."""
    cfg, shared = cbox_store
    shutil.copytree(shared.data_dir, tmp_path / "data")
    cfg = cfg.copy()
    with open_dict(cfg):
        cfg.paths.data_dir = str(tmp_path / "data")
    return cfg, StoreBuilder.from_cfg(cfg)

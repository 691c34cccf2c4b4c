"""A profile or scene name cannot make the store write outside ``paths.data_dir``."""

from __future__ import annotations

import pytest
from omegaconf import open_dict

from mcd.data import StoreBuilder
from tests.conftest import compose_cfg, store32_overrides


def test_a_profile_name_with_dots_is_refused_before_writing(tmp_path):
    cfg = compose_cfg(*store32_overrides(tmp_path / "data"), "data.name=../../outside")
    with pytest.raises(ValueError, match=r"data\.name='\.\./\.\./outside': not a plain folder name"):
        StoreBuilder.from_cfg(cfg).ensure({"ref"}, progress=False)
    assert list(tmp_path.iterdir()) == []


def test_a_scene_key_with_dots_is_refused_before_writing(tmp_path):
    cfg = compose_cfg(*store32_overrides(tmp_path / "data" / "store"))
    with open_dict(cfg):
        cfg.data.scenes["../../x"] = cfg.data.scenes.cbox
        cfg.data.train_scenes = ["../../x"]
        cfg.data.test_scenes = ["../../x"]
    with pytest.raises(ValueError, match=r"data\.scenes key='\.\./\.\./x': not a plain folder name"):
        StoreBuilder.from_cfg(cfg).ensure({"ref"}, progress=False)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("name", ["tiny", "test32", "cornell-box-picture", "staircase2", "room_1.v2"])
def test_ordinary_names_are_accepted(name):
    from mcd.data.store import check_name

    assert check_name(name, "data.name") == name

"""A scene file that cannot render is named before any scene renders (``mcd.data.scenes.SceneSpec
.check_readable``, called by ``StoreBuilder.ensure`` for every scene first; docs/reliability.md, "Campaign
fixes"): a garbage XML file gave Mitsuba's parser error, and one without a camera an IndexError, only when its
turn came, after the scenes before it had rendered; a folder given as a scene was "not found". A data folder
that cannot be made gave a bare FileNotFoundError; it is named with ``paths.data_dir``."""

from __future__ import annotations

import pytest

from mcd.data import StoreBuilder
from tests.conftest import compose_cfg, store32_overrides


def _ensure(tmp_path, scenes: str, data=None) -> None:
    cfg = compose_cfg(*store32_overrides(data or tmp_path / "data"), f"data.train_scenes={scenes}")
    StoreBuilder.from_cfg(cfg).ensure({"c1"}, progress=False)


@pytest.mark.parametrize(("content", "message"), [
    ("garbage <<", r"scene 'bad': .*bad\.xml is not well-formed XML \(syntax error: line 1"),
    ('<scene version="3.0.0"><integrator type="path"/></scene>',
     r"scene 'bad': .*bad\.xml declares no <sensor> \(the camera every frame is rendered from\)"),
])
def test_a_scene_that_cannot_render_is_named_before_the_scenes_before_it_render(tmp_path, content, message):
    (tmp_path / "bad.xml").write_text(content)
    with pytest.raises(ValueError, match=message):
        _ensure(tmp_path, f"[cbox,{tmp_path / 'bad.xml'}]")
    assert not list((tmp_path / "data").rglob("*.exr"))  # cbox, listed first, was not rendered


def test_a_folder_given_as_a_scene_is_named_as_a_folder(tmp_path):
    (tmp_path / "room.xml").mkdir()
    with pytest.raises(FileNotFoundError, match=r"room\.xml is a folder, not a scene file"):
        _ensure(tmp_path, f"[{tmp_path / 'room.xml'}]")


def test_a_data_folder_that_cannot_be_made_is_named_with_its_key(tmp_path):
    with pytest.raises(ValueError, match=r"paths\.data_dir=/proc/mcd-nope \(or MCD_DATA_DIR\): cannot make "
                                         r"the store's folder /proc/mcd-nope/test32"):
        _ensure(tmp_path, "[cbox]", data="/proc/mcd-nope")

"""A frame's lock ``<scene>/<frame>/.lock`` that is a directory, or a frame folder
``<scene>/<frame>`` that is a file, gave a raw OS error. Each is named with its fix before anything is
rendered (mcd/data/store_builder.py); a real render of the 32x32 profile of tests/conftest.py."""

from __future__ import annotations

import pytest

from mcd.data import BUFFERS, StoreBuilder
from tests.conftest import compose_cfg, store32_overrides


@pytest.mark.parametrize("damage", ["lock_is_a_folder", "frame_is_a_file"])
def test_defect22_a_frame_lock_or_folder_of_the_wrong_kind_is_named_before_rendering(tmp_path, damage):
    cfg = compose_cfg(*store32_overrides(tmp_path / "data"))
    frame = tmp_path / "data" / "test32" / "cbox" / "0003"
    if damage == "lock_is_a_folder":
        (frame / ".lock").mkdir(parents=True)
        bad, message = frame / ".lock", "frame 3's lock file is not a regular file; remove it"
    else:
        frame.parent.mkdir(parents=True)
        frame.write_text("not a folder")
        bad, message = frame, "frame 3's folder is a file, not a folder; move it away"
    with pytest.raises(RuntimeError) as err:
        StoreBuilder.from_cfg(cfg).ensure(set(BUFFERS), progress=False)
    assert str(err.value).startswith(f"{bad}: {message}"), err.value
    assert not list((tmp_path / "data").rglob("*.exr"))  # nothing rendered

"""Campaign 11, part 1 (docs/reliability.md, "Campaign fixes"): a lock file is never taken through a symbolic
link.

Campaign 10 left a dangling ``<scene>/.lock`` link of the EXR store: ``mcd.render`` rendered, exit 0, and had
made an empty file where the link pointed, outside the store (low). Every lock (the store's scene and frame
locks, the training store's, ``run.lock``) is taken by :func:`mcd.core.file_lock.exclusive`, which now opens
with ``O_NOFOLLOW`` and refuses a link, naming it and where it points; the store refuses a linked scene or
frame lock before anything is rendered.
"""

from __future__ import annotations

import pytest

from mcd.core.file_lock import LinkedLockError, exclusive
from mcd.data import StoreBuilder
from mcd.data.buffers import BUFFERS
from tests.conftest import compose_cfg, store32_overrides


def test_a_linked_lock_is_refused_and_nothing_is_made_or_changed_where_it_points(tmp_path):
    dangling, user = tmp_path / "dangling.lock", tmp_path / "thesis.tex"
    dangling.symlink_to(tmp_path / "elsewhere" / "made")
    (tmp_path / "elsewhere").mkdir()
    user.write_text("my thesis\n")
    (tmp_path / "user.lock").symlink_to(user)
    for link in (dangling, tmp_path / "user.lock"):
        with pytest.raises(LinkedLockError, match=rf"{link}: this lock file is a symbolic link \(to .*\); "
                                                  r"a lock is taken on a file of its own"), exclusive(link):
            pass
    assert not (tmp_path / "elsewhere" / "made").exists() and user.read_text() == "my thesis\n"
    with exclusive(tmp_path / "own.lock") as f:  # a lock of its own is made and held as before
        assert f is not None


@pytest.mark.parametrize("which", ["scene", "frame"])
def test_a_stores_linked_lock_is_named_before_anything_is_rendered(tmp_path, which):
    cfg = compose_cfg(*store32_overrides(tmp_path / "data"))
    scene = tmp_path / "data" / "test32" / "cbox"
    lock = scene / ".lock" if which == "scene" else scene / "0003" / ".lock"
    lock.parent.mkdir(parents=True)
    (tmp_path / "outside").mkdir()
    lock.symlink_to(tmp_path / "outside" / "lockfile")
    with pytest.raises(RuntimeError, match="lock file is not a regular file; remove it"):
        StoreBuilder.from_cfg(cfg).ensure(set(BUFFERS), progress=False)
    assert not (tmp_path / "outside" / "lockfile").exists()
    assert not (scene / "manifest.json").exists() and not (scene / "0000").exists()

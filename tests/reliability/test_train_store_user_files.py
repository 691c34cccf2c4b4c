"""Campaign 9 (docs/reliability.md): ``python -m mcd.pack`` never writes over a user's files.

``data.train_store.dir=<a folder of the user's>`` holding their own ``cbox.npy`` (another shape) was "packed
again": the pack replaced it with the scene's array and wrote ``store.json``, ``cbox.json`` and ``cbox.lock``
beside it, exit 0. Now a folder without ``store.json`` that holds a scene's ``.npy``, ``.json`` or ``.lock``
is refused before anything is written (:func:`mcd.data.pack.check_unclaimed`), naming the key and the files;
a new or empty folder is packed as before.
"""

from __future__ import annotations

import numpy as np
import pytest

from mcd.data import StoreBuilder
from mcd.data.pack import pack
from tests.conftest import compose_cfg, store32_overrides


def test_a_users_folder_with_a_scene_array_is_refused_and_kept(cbox_store, tmp_path):
    _, shared = cbox_store
    folder = tmp_path / "mine"
    folder.mkdir()
    np.save(folder / "cbox.npy", np.arange(12.0))
    (folder / "notes.txt").write_text("my notes\n")
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    base = [*store32_overrides(shared.data_dir), "+experiment=unet"]
    cfg = compose_cfg(*base, f"data.train_store.dir={folder}")
    with pytest.raises(FileExistsError, match="data.train_store.dir=.*cbox.npy"):
        pack(cfg, StoreBuilder.from_cfg(cfg), ["c4", "ref"])
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before
    empty = tmp_path / "empty"
    empty.mkdir()
    cfg = compose_cfg(*base, f"data.train_store.dir={empty}")
    assert pack(cfg, StoreBuilder.from_cfg(cfg), ["c4", "ref"])["packed"] == 10

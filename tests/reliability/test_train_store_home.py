"""Campaign 8 (docs/reliability.md): ``~`` in the training store's folder is the home folder, as in
``paths.data_dir``. ``data.train_store.dir="~/store"`` packed into a folder literally named ``~`` in the
working directory, and with ``paths.data_dir=~/data`` the default training store went to ``./~/data/...``
while the EXR store it packs went to the home folder's ``data``."""

from __future__ import annotations

from mcd.data.train_store import TrainStoreSettings
from tests.conftest import compose_cfg, store32_overrides


def test_a_store_folder_under_the_home_folder_is_expanded(tmp_path, monkeypatch):
    home = tmp_path / "home"
    home.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.chdir(tmp_path)
    given = compose_cfg(*store32_overrides(tmp_path / "data"), "data.train_store.format=array",
                        'data.train_store.dir="~/store"')
    assert TrainStoreSettings.from_cfg(given).dir == home / "store"
    default = compose_cfg(*store32_overrides('"~/data"'), "data.train_store.format=array")
    assert TrainStoreSettings.from_cfg(default).dir == home / "data" / "test32" / ".train_float32"
    assert not (tmp_path / "~").exists()

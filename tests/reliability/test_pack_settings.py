"""Campaign 8 (docs/reliability.md): ``python -m mcd.pack`` packs only EXR files that its own settings render.
It read the store under ``data.name`` as it was: on a 32x32 store rendered at 256 spp, ``data.ref_spp=64``
said "packed 10 frame(s)" of 256-spp references, and ``data.width=48`` failed on numpy's "could not broadcast
input array from shape (3,32,32) into shape (3,48,48)" after writing the training store's ``store.json``. Now
the pack checks each file's render key against its config first
(:meth:`mcd.data.store_builder.StoreBuilder.check_rendered`), naming the manifest, the settings that differ
and the render command, and writes nothing."""

from __future__ import annotations

import subprocess
import sys

import pytest

from mcd.data import BUFFERS, StoreBuilder
from mcd.data.pack import pack
from tests.conftest import compose_cfg, module_env, store32_overrides


@pytest.mark.parametrize(("override", "named"), [
    ("data.width=48", "width 32 there, 48 here"),
    ("data.ref_spp=64", "ref_spp 256 there, 64 here"),
    ("data.frames_per_segment=5", "frames_per_segment 6 there, 5 here"),
])
def test_a_store_rendered_with_other_settings_is_refused_before_any_work(cbox_store, tmp_path, override,
                                                                          named):
    _, shared = cbox_store
    folder = tmp_path / "packed"
    cfg = compose_cfg(*store32_overrides(shared.data_dir), override, f"data.train_store.dir={folder}")
    with pytest.raises(ValueError, match="rendered with other settings") as err:
        pack(cfg, StoreBuilder.from_cfg(cfg), BUFFERS)
    assert named in str(err.value) and "python -m mcd.render" in str(err.value)
    assert not folder.exists()


@pytest.mark.slow
def test_the_pack_command_refuses_it_and_packs_a_store_of_its_settings(cbox_store, tmp_path):
    _, shared = cbox_store
    base = [sys.executable, "-m", "mcd.pack", "+experiment=unet", *store32_overrides(shared.data_dir)]
    refused = subprocess.run([*base, "data.ref_spp=64", f"data.train_store.dir={tmp_path / 'a'}"],
                             cwd=tmp_path, env=module_env(), capture_output=True, text=True, timeout=600)
    assert refused.returncode != 0 and "ref_spp 256 there, 64 here" in refused.stderr
    assert not (tmp_path / "a").exists()
    packed = subprocess.run([*base, f"data.train_store.dir={tmp_path / 'b'}"], cwd=tmp_path, env=module_env(),
                            capture_output=True, text=True, timeout=600)
    assert packed.returncode == 0, packed.stderr[-3000:]
    assert "packed 10 frame(s)" in packed.stdout + packed.stderr

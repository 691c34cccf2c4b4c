"""Shared fixtures: real tiny Mitsuba renders for tests (owned by the data path, issue 2).

- ``compose_cfg(*overrides)``: the full Hydra config of ``conf/config.yaml`` (what ``python -m mcd.run``
  sees).
- ``store32_overrides(data_dir)``: overrides that turn the ``tiny`` profile into a 32x32, 12-frame,
  Cornell-box-only profile named ``test32`` (ref 256 spp), for quick end-to-end tests.
- ``cbox_store`` (session): ``(cfg, store)`` with every buffer of ``test32`` rendered once per session into a
  temporary folder (about 5 s on 2 cores). Tests must not modify its files; make your own store for that.
- ``cbox32`` (session): ``(scene, renderer)``: the Cornell box loaded at 32x32 in Mitsuba with a box-filter
  :class:`mcd.data.renderer.SceneRenderer` set to the scene's own camera, for direct renders.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mcd.config.compose import compose
from mcd.core.paths import CONF_DIR as _CONF_DIR

CONF_DIR = str(_CONF_DIR)


def compose_cfg(*overrides: str):
    """The composed root config with `overrides` (Hydra command-line syntax)."""
    return compose(overrides)


def store32_overrides(data_dir: Path | str) -> list[str]:
    """A 32x32 Cornell-box profile with 12 frames per sequence: 2 test, 1 validation clip, 1 training clip;
    16-pixel training crops without augmentations (the paper's protocol): a crop is a window of its frame."""
    return [
        "data=tiny",
        "data.name=test32",
        f"paths.data_dir={data_dir}",
        "data.width=32",
        "data.height=32",
        "data.segments=2",
        "data.frames_per_segment=6",
        "data.ref_spp=256",
        "data.gbuffer_spp=8",
        "data.train_scenes=[cbox]",
        "data.test_scenes=[cbox]",
        "data.train_crop=16",
        "data.val_crop=24",
        "data.augment.flips=false",
        "data.augment.transpose=false",
        "data.augment.reverse=false",
    ]


@pytest.fixture(scope="session")
def cbox_store(tmp_path_factory):
    from mcd.data import BUFFERS, StoreBuilder

    cfg = compose_cfg(*store32_overrides(tmp_path_factory.mktemp("store")))
    store = StoreBuilder.from_cfg(cfg)
    store.ensure(set(BUFFERS), progress=False)
    return cfg, store


@pytest.fixture(scope="session")
def cbox32():
    from mcd.data.mitsuba_env import select_variant

    select_variant("auto")
    import mitsuba as mi

    from mcd.data.renderer import SceneRenderer
    from mcd.data.scenes import VENDORED_DIR

    scene = mi.load_file(str(VENDORED_DIR / "cbox" / "scene.xml"), resx=32, resy=32, max_depth=6)
    params = mi.traverse(scene.sensors()[0])
    fov = float(np.asarray(params["x_fov"]).ravel()[0])
    renderer = SceneRenderer(scene, 32, 32, fov)
    renderer.set_camera(np.asarray(params["to_world"].matrix, dtype=np.float64).reshape(4, 4, -1)[..., 0])
    return scene, renderer

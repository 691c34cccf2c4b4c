"""Scenes by path (docs/scenes.md): a scene file named in ``data.*_scenes`` is registered without a config
file; an unregistered name or a scenes folder left unset gets a message that says how to register or find a
scene, never to edit the repository. ``mcd.render`` renders exactly the scenes the same run would read."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from mcd.data import StoreBuilder
from mcd.data.scenes import VENDORED_DIR, SceneNotFoundError, register_paths
from tests.conftest import command_in_worker, compose_cfg, store32_overrides

REPO = Path(__file__).resolve().parents[2]
SMALL = ["data.segments=1", "data.frames_per_segment=2", "data.ref_spp=16", "data.gbuffer_spp=4"]


@pytest.fixture(scope="module")
def my_scene(tmp_path_factory) -> Path:
    """A copy of the Cornell box in a user's own folder, outside the repository."""
    folder = tmp_path_factory.mktemp("user") / "mybox"
    shutil.copytree(VENDORED_DIR / "cbox", folder)
    return folder / "scene.xml"


def test_a_path_in_the_scene_list_registers_the_scene(tmp_path, my_scene):
    cfg = compose_cfg(*store32_overrides(tmp_path), *SMALL, f"data.test_scenes=[{my_scene}]")
    store = StoreBuilder.from_cfg(cfg)
    assert list(cfg.data.test_scenes) == ["mybox"] and store.specs["mybox"].file == my_scene.resolve()
    report = store.ensure({"c4"}, scenes=["mybox"], progress=False)
    assert report["rendered"]["c4"] == 2
    assert store.load("mybox", 1, "c4").shape == (32, 32, 3)
    again = compose_cfg(*store32_overrides(tmp_path), *SMALL, f"data.test_scenes=[{my_scene}]")
    assert StoreBuilder.from_cfg(again).ensure({"c4"}, scenes=["mybox"], progress=False)["rendered"] == {}


def test_a_name_clash_is_refused(tmp_path, my_scene):
    other = tmp_path / "cbox" / "scene.xml"
    other.parent.mkdir()
    other.write_text(my_scene.read_text())
    cfg = compose_cfg("data=tiny", f"data.test_scenes=[{other}]")
    with pytest.raises(ValueError, match=r"registered as scene 'cbox', which already names .*\+data\.scenes"):
        register_paths(cfg)


def test_an_unregistered_name_says_how_to_register_it(tmp_path):
    cfg = compose_cfg("data=tiny", f"paths.data_dir={tmp_path}", "data.test_scenes=[kitchen]")
    with pytest.raises(ValueError) as err:
        StoreBuilder.from_cfg(cfg)
    msg = str(err.value)
    assert "data.test_scenes=[path/to/scene.xml]" in msg and "+data.scenes.kitchen=" in msg
    assert "conf/" not in msg  # never: edit the repository's configs


def test_a_scene_outside_the_repository_needs_the_scenes_folder(tmp_path, monkeypatch):
    monkeypatch.delenv("MCD_SCENES_DIR", raising=False)
    cfg = compose_cfg("data=small", f"paths.data_dir={tmp_path}")
    assert cfg.paths.scenes_dir is None
    store = StoreBuilder.from_cfg(cfg)
    with pytest.raises(SceneNotFoundError, match=r"'staircase2'|'bathroom'") as err:
        store.ensure({"c4"}, progress=False)
    assert "MCD_SCENES_DIR" in str(err.value) and "docs/scenes.md" in str(err.value)


@pytest.mark.slow
def test_render_of_a_transfer_run_renders_the_transfer_scene_only(tmp_path, my_scene):
    ckpt = tmp_path / "trained.ckpt"
    ckpt.write_bytes(b"not read by mcd.render")  # the run it mirrors would load it; rendering does not
    data = tmp_path / "data"
    args = [*store32_overrides(data), *SMALL, f"transfer.init_from={ckpt}",
            f"data.transfer_scenes=[{my_scene}]", "render.buffers=[c4]",
            f"hydra.run.dir={tmp_path / 'hydra'}"]
    done = command_in_worker("mcd.render", args, REPO, {"PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"})
    assert done.returncode == 0, done.stderr[-2000:]
    assert sorted(p.name for p in (data / "test32").iterdir()) == ["mybox"]  # not the training scene


def test_the_documented_registrations_compose(tmp_path):
    """docs/scenes.md: one override with the scene's settings, or a config file in the user's own folder."""
    inline = compose_cfg("data=tiny", "+data.scenes.kitchen={kind: xml, file: /abs/kitchen/scene.xml, "
                         "exposure: auto, path: {dolly: 0.2, truck: 0.1, pan_deg: 5}}",
                         "data.test_scenes=[kitchen]")
    assert inline.data.scenes.kitchen.path.dolly == 0.2
    (tmp_path / "scene").mkdir()
    (tmp_path / "scene" / "kitchen.yaml").write_text("kind: xml\nfile: /abs/kitchen/scene.xml\n")
    own = compose_cfg("data=tiny", f"hydra.searchpath=[file://{tmp_path}]",
                      "+scene@data.scenes.kitchen=kitchen", "data.test_scenes=[kitchen]")
    assert own.data.scenes.kitchen.file == "/abs/kitchen/scene.xml"
    doc = (REPO / "docs" / "scenes.md").read_text()
    assert "+data.scenes.kitchen={kind: xml" in doc and "hydra.searchpath=[file://" in doc


@pytest.mark.slow
def test_a_run_trains_and_tests_on_a_scene_given_by_path(tmp_path, my_scene):
    """``mcd.run`` reads the scene the path names (the datamodule gets the registered name)."""
    args = ["+experiment=unet", "data.width=32", "data.height=32", "data.frames_per_segment=6",
            "data.ref_spp=16", "data.gbuffer_spp=2", "data.train_crop=32", "data.val_crop=32",
            f"data.train_scenes=[{my_scene}]", f"data.test_scenes=[{my_scene}]", "train.batch_size=1",
            "train.epochs=1", "train.max_steps=1",
            "trainer.enable_progress_bar=false", f"paths.data_dir={tmp_path / 'data'}",
            f"hydra.run.dir={tmp_path / 'run'}"]
    done = command_in_worker("mcd.run", args, REPO, {"PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"})
    assert done.returncode == 0, done.stderr[-3000:]
    metrics = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert metrics["scenes_test"] == ["mybox"] and metrics["test_frames"] == {"mybox": 2}

"""A bad budget, an image smaller than the SSIM window, a missing scene file and a
missing configured folder (``paths.scenes_dir``, ``paths.data_dir``) fail before anything is
rendered or trained, each with a message that says what to give."""

from __future__ import annotations

import time

import pytest

from mcd.data import StoreBuilder
from mcd.data.scenes import SceneNotFoundError
from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides


def _run(tmp_path, *overrides: str) -> None:
    cfg = compose_cfg(*store32_overrides(tmp_path / "data"), *overrides)
    train_and_test(cfg, tmp_path / "run", {}, time.perf_counter())


@pytest.mark.parametrize(("budget", "message"), [
    ("abc", r"budget='abc': not a number; give the average samples per pixel, one of 1, 2, 4, 8, 16, 32"),
    ("3", r"budget=3: every run is compared with the noisy uniform render at the budget \(c_s\), which the "
          r"store holds for s in 1, 2, 4, 8, 16, 32 only"),
    ("3.5", r"budget=3.5: every run is compared"),
])
def test_a_bad_budget_names_the_rule_before_rendering(tmp_path, budget, message):
    with pytest.raises(ValueError, match=message):
        _run(tmp_path, "+experiment=F", f"budget={budget}")
    assert not (tmp_path / "data").exists()


def test_an_image_below_the_ssim_window_fails_before_rendering(tmp_path):
    with pytest.raises(ValueError, match=r"data\.width=1 data\.height=1: .*SSIM.*at least 7x7"):
        _run(tmp_path, "+experiment=A", "data.width=1", "data.height=1")
    assert not (tmp_path / "data").exists()


@pytest.mark.parametrize(("override", "message"), [
    ("data.train_crop=64", r"data\.train_crop=64 is larger than the 32x32 frames.*give "
                           r"data\.train_crop <= 32"),
    ("data.train_crop_at_edge=-0.1", r"data\.train_crop_at_edge=-0\.1: give a number from 0 to 1 \(a "
                                     r"probability"),
    ("data.train_clip_stride=0", r"data\.train_clip_stride=0: give a whole number from 1 to 5 "
                                 r"\(data\.clip_len\)"),
    ("data.train_clip_stride=6", r"data\.train_clip_stride=6: give a whole number from 1 to 5"),
    ("data.train_clip_stride=2.5", r"data\.train_clip_stride=2\.5: give a whole number from 1 to 5"),
])
def test_a_bad_training_crop_fails_before_rendering(tmp_path, override, message):
    with pytest.raises(ValueError, match=message):
        _run(tmp_path, "+experiment=A", override)
    assert not (tmp_path / "data").exists()


def test_reversed_clips_for_a_method_that_reads_motion_fail_before_rendering(tmp_path):
    with pytest.raises(ValueError, match=r"data\.augment\.reverse=true: this method reads the motion buffer"):
        _run(tmp_path, "+experiment=ntasad", "data.augment.reverse=true")
    assert not (tmp_path / "data").exists()


def test_a_missing_scene_file_fails_before_the_first_scene_renders(tmp_path):
    (tmp_path / "empty").mkdir()
    cfg = compose_cfg(*store32_overrides(tmp_path / "data"), "+scene@data.scenes.bathroom=bathroom",
                      "data.train_scenes=[cbox,bathroom]", f"paths.scenes_dir={tmp_path / 'empty'}")
    missing = r"scene 'bathroom': file .*empty.* not found; set paths\.scenes_dir"
    with pytest.raises(SceneNotFoundError, match=missing):
        StoreBuilder.from_cfg(cfg).ensure({"ref"}, progress=False)
    assert not (tmp_path / "data").exists()  # cbox, listed first, was not rendered


def test_a_missing_scenes_dir_is_named_with_its_key_before_rendering(tmp_path):
    """``paths.scenes_dir`` (conf/paths/default.yaml) set to no folder fails when the store is made, even if
    every scene of the profile is vendored, naming the key and the variable (mcd.core.paths.scenes_dir)."""
    message = r"paths\.scenes_dir=.*nowhere \(or MCD_SCENES_DIR\): no such folder; set it to the folder"
    with pytest.raises(ValueError, match=message):
        _run(tmp_path, "+experiment=A", f"paths.scenes_dir={tmp_path / 'nowhere'}")
    assert not (tmp_path / "data").exists()


@pytest.mark.parametrize("value", ["file", "''"])
def test_a_data_dir_that_is_a_file_or_empty_is_named_with_its_key_before_rendering(tmp_path, value):
    (tmp_path / "file").write_text("not a folder")
    given = tmp_path / "file" if value == "file" else value
    message = r"paths\.data_dir=.*file \(or MCD_DATA_DIR\) is a file" if value == "file" else \
        r"paths\.data_dir is empty"
    with pytest.raises(ValueError, match=message):
        _run(tmp_path, "+experiment=A", f"paths.data_dir={given}")
    assert (tmp_path / "file").read_text() == "not a folder"


def test_paths_is_a_config_group_whose_keys_the_environment_sets(tmp_path, monkeypatch):
    """The folders come from ``conf/paths/default.yaml`` (a group, ``paths=<name>``), which reads
    ``MCD_DATA_DIR`` and ``MCD_SCENES_DIR``."""
    from omegaconf import OmegaConf

    from mcd.core.paths import CONF_DIR

    assert (CONF_DIR / "paths" / "default.yaml").is_file()
    assert "paths" not in OmegaConf.load(CONF_DIR / "config.yaml")  # the group is the one home of the keys
    monkeypatch.setenv("MCD_DATA_DIR", str(tmp_path / "d"))
    monkeypatch.setenv("MCD_SCENES_DIR", str(tmp_path / "s"))
    cfg = compose_cfg()
    assert (cfg.paths.data_dir, cfg.paths.scenes_dir) == (str(tmp_path / "d"), str(tmp_path / "s"))
    assert cfg.paths.vgg16_weights is None

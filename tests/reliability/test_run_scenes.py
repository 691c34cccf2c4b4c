"""A run with no scene to test on trained to its budget, then failed writing ``metrics.json``
("run_record needs the test's averages"); a trained method with no scene to train on rendered its test
scenes, then failed inside Lightning ("num_samples should be a positive integer value"). Both are refused by
``mcd.run``'s preflight (``mcd.config.preflight.check_scenes``) naming the key, before anything is rendered
(docs/reliability.md, "Campaign fixes")."""

from __future__ import annotations

import time

import pytest

from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides


def _run(tmp_path, *overrides: str) -> dict:
    cfg = compose_cfg(*store32_overrides(tmp_path / "data"), "train.max_steps=1", *overrides)
    return train_and_test(cfg, tmp_path / "run", {}, time.perf_counter())


@pytest.mark.parametrize(("override", "message"), [
    ("data.test_scenes=[]", r"data\.test_scenes is empty \(profile test32\): a run is scored on its test "
                            r"scenes; name at least one"),
    ("data.train_scenes=[]", r"data\.train_scenes is empty \(profile test32\) and method unet trains: "
                             r"name at least one"),
])
def test_a_run_without_test_or_training_scenes_is_refused_before_rendering(tmp_path, override, message):
    with pytest.raises(ValueError, match=message):
        _run(tmp_path, "+experiment=unet", override)
    assert not (tmp_path / "data").exists()  # nothing rendered
    assert not (tmp_path / "run" / "checkpoints").exists()  # nothing trained


def test_an_untrained_method_needs_no_training_scenes(cbox_store, tmp_path):
    cfg = compose_cfg(*store32_overrides(cbox_store[1].data_dir), "+experiment=noisy", "data.train_scenes=[]")
    metrics = train_and_test(cfg, tmp_path / "run", {}, time.perf_counter())
    assert metrics["scenes_test"] == ["cbox"] and metrics["psnr"] == metrics["input_psnr"]

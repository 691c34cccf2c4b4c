"""Campaign 11, part 1 (docs/reliability.md, "Campaign fixes"): a run is not resumed, or skipped as
finished, on other scenes or at another precision of its training values.

The job's identity named the scenes (``data.train_scenes``, ...), not what they are made of. A run killed
after step 4 and resumed with ``ckpt_path=auto data.scenes.cbox.path.dolly=0.9`` had the store render 11 of
its 12 frames again from the new camera path, trained steps 5-8 and was tested on them, exit 0, its
``metrics.json`` ``data_settings`` equal to the first process's (high: a silent wrong result, one record over
two sets of frames); a rerun into the finished run was skipped as finished. A resume that switched to a
float16 pack (``data.train_store.format=array data.train_store.dtype=float16``) trained its last steps on
rounded frames, its record naming float16 only (medium). Now ``job.json`` records the scenes' file digests,
camera paths and exposures and the training values' precision, and such a resume (or, for the scenes, such a
rerun) is refused naming the keys, before anything is rendered. The same for a scene given by its file's
path and edited in place (its light made brighter): the store rendered all 12 frames again and the resume
trained on them, exit 0.
"""

from __future__ import annotations

import shutil
import time

import pytest

from mcd.data.scenes import VENDORED_DIR
from mcd.lit.run_record import check_same_job
from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides
from tests.reliability.test_resume import FROZEN

CHOICES = {"data": "tiny"}


@pytest.mark.slow
def test_a_resume_on_other_scenes_or_values_is_refused_and_a_rerun_not_skipped(own_interrupted):
    run, overrides, store = own_interrupted  # row A killed after its checkpoint
    last = run / "checkpoints" / "last.ckpt"
    manifest = store.manifest_path("cbox")
    before, frames = last.read_bytes(), manifest.read_bytes()

    moved = compose_cfg(*overrides, "train.epochs=2", "data.scenes.cbox.path.dolly=0.9", "ckpt_path=auto")
    with pytest.raises(FileExistsError, match=rf"{run} holds an interrupted run of other scenes "
                                              r"\(data\.scenes\.cbox\.path\.dolly: 0\.45 there, 0\.9 here\)"):
        train_and_test(moved, run, CHOICES, time.perf_counter())
    half = compose_cfg(*overrides, "train.epochs=2", "data.train_store.format=array",
                       "data.train_store.dtype=float16", "ckpt_path=auto")
    with pytest.raises(FileExistsError, match=r"another precision \(data\.train_store\.dtype: 'float32' "
                                              r"there, 'float16' here\)"):
        train_and_test(half, run, CHOICES, time.perf_counter())
    assert last.read_bytes() == before and manifest.read_bytes() == frames  # nothing rendered or trained
    assert not (run / "metrics.json").exists()

    same = compose_cfg(*overrides, "train.epochs=2", "ckpt_path=auto")
    train_and_test(same, run, CHOICES, time.perf_counter())  # the same scenes resume to the end
    check_same_job(run / "metrics.json", same, CHOICES)  # and a rerun of them is skipped
    with pytest.raises(FileExistsError, match=r"holds a finished run of other scenes "
                                              r"\(data\.scenes\.cbox\.exposure: 'auto' there, 2\.0 here\)"):
        check_same_job(run / "metrics.json", compose_cfg(*overrides, "data.scenes.cbox.exposure=2.0"),
                       CHOICES)


@pytest.mark.slow
def test_a_resume_of_a_scene_file_edited_in_place_is_refused(tmp_path):
    shutil.copytree(VENDORED_DIR / "cbox", tmp_path / "mybox")
    scene = tmp_path / "mybox" / "scene.xml"
    lists = [f"data.train_scenes=[{scene}]", f"data.test_scenes=[{scene}]"]
    overrides = [*(o for o in store32_overrides(tmp_path / "data") if "_scenes=" not in o), *lists, *FROZEN]
    run = tmp_path / "run"
    train_and_test(compose_cfg(*overrides, "train.epochs=1"), run, CHOICES, time.perf_counter())
    (run / "metrics.json").unlink()
    scene.write_text(scene.read_text() + "<!-- the light made brighter -->\n")
    with pytest.raises(FileExistsError, match=r"holds an interrupted run of other scenes "
                                              r"\(data\.scenes\.mybox\.file_sha256: '[0-9a-f]{64}' there, "
                                              r"'[0-9a-f]{64}' here\)"):
        train_and_test(compose_cfg(*overrides, "train.epochs=2", "ckpt_path=auto"), run, CHOICES,
                       time.perf_counter())

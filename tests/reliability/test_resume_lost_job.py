"""Campaign 12, part 1 (docs/reliability.md, "Campaign fixes"): a resume is checked against the job its
checkpoint was trained as, also where the run directory's ``job.json`` is lost; ``metrics.json``
``data_settings`` names what each scene is made of.

Campaign 11 left both. An interrupted run (``last.ckpt``, no ``metrics.json``) whose ``job.json`` was
lost, resumed with ``ckpt_path=auto seed=1`` (or another camera path), trained its last steps and was tested,
exit 0, its record naming seed 1 (or the new path) for a checkpoint whose first steps trained under seed 0
(the old one). Now every checkpoint holds the job's record (``mcd.lit.segments.TrainingSegments``: ``job``)
and such a resume is refused naming the keys, before anything is rendered or written. ``data_settings``
held the scene lists only, so ``mcd.report`` put runs of other camera paths into one cell; it now holds
``scenes.<name>.*`` (the camera path, exposure, file digests), and the report names the runs' profiles
apart.
"""

from __future__ import annotations

import json
import shutil
import time

import pytest

from mcd.lit.run_record import check_same_job
from mcd.report import profiles_of
from mcd.reporting.runs import load_run
from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides
from tests.reliability.test_resume import FROZEN

CHOICES = {"data": "tiny"}


@pytest.mark.slow
def test_a_resume_after_job_json_is_lost_is_checked_against_the_checkpoint(own_interrupted, tmp_path):
    run, overrides, store = own_interrupted  # row A killed after its checkpoint
    (run / "job.json").unlink()  # and its record lost
    last = run / "checkpoints" / "last.ckpt"
    manifest = store.manifest_path("cbox")
    before, frames = last.read_bytes(), manifest.read_bytes()

    for change, message in (("seed=1", r"holds steps of another job \(seed: 0 there, 1 here\)"),
                            ("data.scenes.cbox.path.dolly=0.9", r"holds steps of other scenes "
                             r"\(data\.scenes\.cbox\.path\.dolly: 0\.45 there, 0\.9 here\)"),
                            ("train.lr=0.5", r"holds steps trained with other optimiser settings")):
        other = compose_cfg(*overrides, "train.epochs=2", change, "ckpt_path=auto")
        with pytest.raises(FileExistsError, match=rf"{last} {message}"):
            train_and_test(other, run, CHOICES, time.perf_counter())
    assert last.read_bytes() == before and manifest.read_bytes() == frames  # nothing rendered or trained
    assert not (run / "job.json").exists() and not (run / "metrics.json").exists()

    train_and_test(compose_cfg(*overrides, "train.epochs=2", "ckpt_path=auto"), run, CHOICES,
                   time.perf_counter())  # the same job resumes to its end
    settings = json.loads((run / "metrics.json").read_text())["data_settings"]
    assert settings["scenes.cbox.path.dolly"] == 0.45 and settings["scenes.cbox.exposure"] == "auto"
    assert len(settings["scenes.cbox.file_sha256"]) == 64
    (run / "job.json").unlink()  # a finished run whose job.json is lost is not skipped for another path
    moved_path = compose_cfg(*overrides, "data.scenes.cbox.path.dolly=0.9")
    with pytest.raises(FileExistsError, match=r"another job \(data\.scenes\.cbox\.path\.dolly"):
        check_same_job(run / "metrics.json", moved_path, CHOICES)

    moved = tmp_path / "moved"  # a run of another camera path: its report cell is its own
    shutil.copytree(run, moved)
    record = json.loads((moved / "metrics.json").read_text())
    record["data_settings"]["scenes.cbox.path.dolly"] = 0.9
    (moved / "metrics.json").write_text(json.dumps(record))
    labels = profiles_of([load_run(run), load_run(moved)])
    assert labels == {"`tiny` (scenes.cbox.path.dolly=0.45)": 1, "`tiny` (scenes.cbox.path.dolly=0.9)": 1}


@pytest.mark.slow
def test_a_checkpoint_of_another_run_is_not_resumed_under_another_seed(own_store, tmp_path):
    """``mcd.run -m seed=0,1 ckpt_path=<run>/checkpoints/last.ckpt`` (or a single run from another
    directory's checkpoint with ``data.ref_spp=64``) trained every job on from the one checkpoint, exit 0: the
    seed-1 job's record named seed 1, its scores equal to seed 0's (high: a seeds study with no spread). Also
    a checkpoint from before the record is checked, against its run directory's ``job.json``."""
    import torch

    cfg, store = own_store
    overrides = [*store32_overrides(store.data_dir), *FROZEN]
    first = tmp_path / "first"
    train_and_test(compose_cfg(*overrides, "train.epochs=1"), first, CHOICES, time.perf_counter())
    last = first / "checkpoints" / "last.ckpt"
    for change, message in (("seed=1", r"another job \(seed: 0 there, 1 here\)"),
                            ("data.ref_spp=64", r"another job \(data\.ref_spp: 256 there, 64 here\)")):
        other = compose_cfg(*overrides, "train.epochs=2", change, f"ckpt_path={last}")
        with pytest.raises(FileExistsError, match=rf"{last} holds steps of {message}"):
            train_and_test(other, tmp_path / change, CHOICES, time.perf_counter())
        assert not (tmp_path / change).exists()  # nothing written

    state = torch.load(last, map_location="cpu", weights_only=True)  # a checkpoint from before the record
    del state["callbacks"]["TrainingSegments"]["job"]
    old = first / "checkpoints" / "old.ckpt"
    torch.save(state, old)
    with pytest.raises(FileExistsError, match=rf"{old} holds steps of another job \(seed: 0 there, 1 here\)"):
        train_and_test(compose_cfg(*overrides, "train.epochs=2", "seed=1", f"ckpt_path={old}"),
                       tmp_path / "old", CHOICES, time.perf_counter())
    train_and_test(compose_cfg(*overrides, "train.epochs=2", f"ckpt_path={old}"), tmp_path / "same",
                   CHOICES, time.perf_counter())  # the same job trains on from it in another directory
    assert (tmp_path / "same" / "metrics.json").is_file()

"""An interrupted run is not resumed on other data. The job's identity
(``mcd.lit.run_record.job_identity``, ``job.json``) holds what determines the data
(``mcd.data.store.store_settings``), so ``ckpt_path=auto`` with another ``data.name`` and size is refused
naming the keys that differ, before anything is rendered; the same data still resumes."""

from __future__ import annotations

import json
import time

import pytest

from mcd.run import train_and_test
from tests.conftest import compose_cfg


@pytest.mark.slow
def test_defect12_an_interrupted_run_resumed_on_other_data_is_refused_naming_the_keys(own_interrupted):
    run, overrides, store = own_interrupted
    last = run / "checkpoints" / "last.ckpt"
    before = last.stat().st_mtime_ns

    other = compose_cfg(*overrides, "data.name=other48", "data.width=48", "data.height=48", "train.epochs=2",
                        "ckpt_path=auto")
    with pytest.raises(FileExistsError, match=rf"{run} holds an interrupted run of another job \(data\.name: "
                                              r"'test32' there, 'other48' here; data\.width: 32 there, 48 "
                                              r"here; data\.height: 32 there, 48 here\); give this run its "
                                              r"own directory"):
        train_and_test(other, run, {"data": "tiny"}, time.perf_counter())
    assert last.stat().st_mtime_ns == before and not (run / "metrics.json").exists()
    assert not (store.data_dir / "other48").exists()  # refused before anything was rendered

    # the same data resumes the run to its end, and its record holds the data it trained on
    train_and_test(compose_cfg(*overrides, "train.epochs=2", "ckpt_path=auto"), run, {"data": "tiny"},
                   time.perf_counter())
    m = json.loads((run / "metrics.json").read_text())
    assert m["train_steps"] == 2 and m["data_settings"]["name"] == "test32"
    assert m["data_settings"]["width"] == 32 and m["data_settings"]["train_scenes"] == ["cbox"]
    assert json.loads((run / "job.json").read_text())["data_settings"] == m["data_settings"]

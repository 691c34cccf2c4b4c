"""A packed training store without a buffer of the run (packed by a U-Net run, trained
from by row F) is refused before anything is rendered, naming the store, the buffers it lacks and the fix;
a store not packed yet is still packed by the run."""

from __future__ import annotations

import time

import pytest

from mcd.data import StoreBuilder
from mcd.data.buffers import run_buffers
from mcd.data.pack import pack
from mcd.data.train_store import TrainStoreError
from mcd.models import build as build_model
from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides


def _files(folder) -> set[str]:
    return {str(p.relative_to(folder)) for p in folder.rglob("*")}


@pytest.mark.slow
def test_defect9_a_store_packed_without_the_runs_buffers_is_refused_before_rendering(tmp_path):
    data, ts = tmp_path / "data", tmp_path / "ts"
    common = [*store32_overrides(data), "data.train_store.format=array", f"data.train_store.dir={ts}"]
    unet = compose_cfg(*common, "+experiment=unet")
    buffers = run_buffers(build_model(unet).required_buffers(), unet.budget)
    store = StoreBuilder.from_cfg(unet)
    store.ensure(buffers, progress=False)
    pack(unet, store, buffers)
    before = _files(data), _files(ts)

    cfg = compose_cfg(*common, "+experiment=F", "train.max_steps=1")
    with pytest.raises(TrainStoreError, match=rf"the training store {ts} holds buffers .*this run also reads "
                                              r"\[.*'c1_in'.*'c32'.*\]; give another data\.train_store\.dir, "
                                              rf"or delete {ts} and pack it again"):
        train_and_test(cfg, tmp_path / "run", {}, time.perf_counter())
    assert (_files(data), _files(ts)) == before  # nothing rendered, nothing packed

    # the fix: another data.train_store.dir, not packed yet, is packed by the run as before
    fresh = tmp_path / "ts_f"
    cfg = compose_cfg(*store32_overrides(data), "data.train_store.format=array",
                      f"data.train_store.dir={fresh}", "+experiment=F", "train.max_steps=1")
    train_and_test(cfg, tmp_path / "run_f", {}, time.perf_counter())
    assert (fresh / "store.json").is_file() and (fresh / "cbox.npy").is_file()

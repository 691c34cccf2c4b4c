"""Campaign 8 (docs/reliability.md): a run's ``metrics.json`` counts the values of its data changed before
the model saw them. NaN, Inf and negative pixels in store frames were replaced by 0 at load and named in the
log only (campaign 7 left it: ``metrics.json`` had no count), and values clamped to the float16 range by
the training store's pack were counted in the pack's log line only. Now ``data.replaced_by_0`` counts the
replaced values (values, files, per buffer) in the frames the run read, training, validation and test, and
with ``data.train_store.format=array`` ``data.train_store.clamped_total`` the clamped ones."""

from __future__ import annotations

import json

import numpy as np
import pytest

from mcd.data.exr import read_exr, sha256, write_exr
from tests.conftest import mcd_run, store32_overrides


def _damage(store, frame: int, buffer: str, values: list[float]) -> None:
    """Write ``values`` into the first pixels of one stored EXR and record the file in its manifest as the
    renderer would have left it (bytes, checksum, NaN / Inf / negative counts)."""
    path = store.path("cbox", frame, buffer)
    img = read_exr(path)
    flat = img.reshape(-1)
    flat[: len(values)] = values
    write_exr(path, img, compress=False)
    man_path = store.manifest_path("cbox")
    man = json.loads(man_path.read_text())
    man["files"][f"{frame:04d}/{buffer}.exr"].update(
        bytes=path.stat().st_size, sha256=sha256(path), nan=int(np.isnan(img).sum()),
        inf=int(np.isinf(img).sum()), negative=int((np.isfinite(img) & (img < 0)).sum()))
    man_path.write_text(json.dumps(man))


@pytest.mark.slow
def test_values_replaced_by_0_and_clamped_to_float16_are_counted_in_metrics_json(own_store, tmp_path):
    cfg, store = own_store
    for f in range(12):  # the clean store holds none (so every count below is the damage's)
        for b in ("c4", "ref", "albedo"):
            rec = store.manifest("cbox")["files"][f"{f:04d}/{b}.exr"]
            assert rec.get("nan", 0) == rec.get("inf", 0) == rec.get("negative", 0) == 0
    # frames 0-1 are tested, 2-6 validated, 7-11 trained on (store32_overrides' split)
    _damage(store, 9, "c4", [np.nan] * 3)  # a training frame
    _damage(store, 0, "ref", [np.inf, -np.inf])  # a test frame
    _damage(store, 4, "albedo", [-1.0] * 4)  # a validation frame
    _damage(store, 8, "ref", [1e9])  # finite: kept as HDR, but beyond float16's range once packed
    run = tmp_path / "run"
    packed = tmp_path / "packed"
    proc = mcd_run("+experiment=unet", *store32_overrides(store.data_dir), "train.max_steps=1",
                   "train.sample_frames=[]", "trainer.enable_progress_bar=false",
                   "data.train_store.format=array", "data.train_store.dtype=float16",
                   f"data.train_store.dir={packed}", f"hydra.run.dir={run}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    data = json.loads((run / "metrics.json").read_text())["data"]
    assert data["replaced_by_0"] == {"values": 9, "files": 3, "by_buffer": {"c4": 3, "ref": 2, "albedo": 4}}
    assert data["train_store"]["clamped_total"] == 1 and data["train_store"]["packed"] == 10
    said = "9 NaN/Inf/negative value(s) in 3 file(s) of this run's data were replaced by 0"
    assert said in proc.stdout + proc.stderr

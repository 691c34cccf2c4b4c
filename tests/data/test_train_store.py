"""The training store and its pack (mcd/data/train_store.py, mcd/data/pack.py, docs/training_store.md): crops
bit-identical to the EXR path's, float16 clamped and counted, a killed pack resumes, another config refused
naming the key, and the datamodule's loaders (workers, DDP shares) over it."""

from __future__ import annotations

import json
import logging
import os
import pickle
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import torch
from omegaconf import OmegaConf

from mcd.data import BUFFERS, MCDDataModule, StoreReader
from mcd.data.clips import ExrClips
from mcd.data.pack import frames_to_pack, pack
from mcd.data.synthetic_store import synthetic_data_cfg, write_synthetic_store
from mcd.data.train_store import FP16_MAX, TrainStore, TrainStoreError, TrainStoreSettings
from tests.conftest import compose_cfg, store32_overrides

REPO = Path(__file__).resolve().parents[2]


def _array_cfg(data_dir, folder, *extra):
    return compose_cfg(*store32_overrides(data_dir), "data.train_store.format=array",
                       f"data.train_store.dir={folder}", *extra)


def _open(cfg, buffers=BUFFERS) -> TrainStore:
    return TrainStore.open(TrainStoreSettings.from_cfg(cfg), cfg.data, buffers, "pack it")


def test_crops_are_bit_identical_to_the_exr_path(cbox_store, tmp_path):
    _, store = cbox_store
    cfg = _array_cfg(store.data_dir, tmp_path / "ts")
    report = pack(cfg, store, BUFFERS)
    frames = frames_to_pack(store, "cbox", cfg.data)
    assert report["packed"] == len(frames) == 10 and report["clamped"] == 0
    ts, exr = _open(cfg), ExrClips(store, list(BUFFERS), cache=False)
    for clip, crop in [([2, 3, 4, 5, 6], (0, 0, 16, 16)), ([7, 8, 9, 10, 11], (5, 11, 16, 21)),
                       ([3], (0, 0, 32, 32)), ([9, 10], (31, 0, 1, 32))]:
        a, b = ts.clip("cbox", clip, crop), exr.clip("cbox", clip, crop)
        for buf in BUFFERS:
            assert a[buf].dtype == torch.float32 and a[buf].shape == b[buf].shape
            assert torch.equal(a[buf], b[buf]), (buf, clip, crop)
        assert torch.equal(a["frame"], b["frame"])
    # packed again: nothing to do
    assert pack(cfg, store, BUFFERS)["reused"] == 10
    with pytest.raises(ValueError, match=r"crop \(20, 0, 16, 16\).*outside the 32x32 frames"):
        ts.clip("cbox", [2], (20, 0, 16, 16))


def test_crops_across_tiles_of_an_odd_sized_frame_are_bit_identical(tmp_path):
    """A 203x141 frame is 4x3 tiles of 64, the last ones padded: crops across tile edges, at the frame's far
    edges and the whole frame read what the EXR path reads, for a subset of the packed buffers."""
    data_cfg = synthetic_data_cfg("odd", "synth", 203, 141, 11)
    write_synthetic_store(tmp_path / "exr", data_cfg, ["c1_in", "c4", "ref", "depth", "normal"], seed=3)
    cfg = OmegaConf.create({"data": data_cfg, "paths": {"data_dir": str(tmp_path / "exr")}})
    cfg.data.train_store = {"format": "array", "dtype": "float32", "dir": str(tmp_path / "ts")}
    reader = StoreReader(tmp_path / "exr", cfg.data, overrides=[])
    pack(cfg, reader, ["c1_in", "c4", "ref", "depth", "normal"])
    ts = _open(cfg, ["c1_in", "ref", "normal"])  # two runs of stored channels: c1_in, then ref + ... normal
    assert np.load(ts.scene_path("synth"), mmap_mode="r").shape == (11, 3, 4, 13, 64, 64)
    exr = ExrClips(reader, ["c1_in", "ref", "normal"], cache=False)
    for frames, crop in [([1, 2, 3], (60, 60, 70, 80)), ([6], (0, 0, 141, 203)), ([4, 5], (77, 139, 64, 64)),
                         ([10], (140, 202, 1, 1)), ([2], (0, 63, 141, 2))]:
        a, b = ts.clip("synth", frames, crop), exr.clip("synth", frames, crop)
        assert set(a) == set(b)
        for buf in ("c1_in", "ref", "normal"):
            assert torch.equal(a[buf], b[buf]), (buf, frames, crop)


def test_the_datamodule_reads_the_same_clips_from_either_store(cbox_store, tmp_path):
    cfg_exr, store = cbox_store
    cfg = _array_cfg(store.data_dir, tmp_path / "ts", "data.num_workers=2")
    buffers = ["c1_in", "c4", "normal"]
    with pytest.raises(TrainStoreError, match=r"no training store.*pack it first: python -m mcd\.pack"):
        MCDDataModule(cfg, store, buffers)
    pack(cfg, store, BUFFERS)  # a superset of what the datamodule reads
    dm_exr, dm = MCDDataModule(cfg_exr, store, buffers), MCDDataModule(cfg, store, buffers)
    dm_exr.setup(), dm.setup()
    assert isinstance(dm.train_set.frames, TrainStore) and isinstance(dm_exr.train_set.frames, ExrClips)
    (a,), (b,) = list(dm.val_dataloader()), list(dm_exr.val_dataloader())  # centre crops
    assert set(a) == {"c1_in", "c4", "normal", "ref", "scene", "frame"}
    for k in ("c1_in", "c4", "normal", "ref", "frame"):
        assert torch.equal(a[k], b[k]), k
    # two persistent workers, each with its own memory maps (the store pickles without them)
    loader = dm.train_dataloader()
    assert loader.num_workers == 2 and loader.persistent_workers
    for _ in range(2):
        (batch,) = list(loader)
        assert batch["ref"].shape == (1, 5, 3, 16, 16) and torch.isfinite(batch["ref"]).all()
    dm.train_set.frames.clip("cbox", [2], None)
    assert dm.train_set.frames._maps and pickle.loads(pickle.dumps(dm.train_set.frames))._maps == {}


def test_each_ddp_rank_reads_its_own_share_of_clips(cbox_store, tmp_path):
    _, store = cbox_store
    cfg = _array_cfg(store.data_dir, tmp_path / "ts", "data.test_fraction=0.1", "data.clip_len=2",
                     "train.batch_size=1")
    pack(cfg, store, BUFFERS)
    dm = MCDDataModule(cfg, store, ["c1_in"])
    dm.setup()
    shares = []
    for rank in range(2):
        dm._ranks = lambda rank=rank: (rank, 2)
        shares.append([tuple(b["frame"][0].tolist()) for b in dm.train_dataloader()])
    assert len(dm.train_set) == 4 and all(len(s) == 2 for s in shares)
    assert set(shares[0]).isdisjoint(shares[1])
    assert set(shares[0]) | set(shares[1]) == {tuple(c) for _, c in dm.train_set.clips}


def test_float16_clamps_and_counts_values_beyond_its_range(cbox_store, tmp_path, caplog):
    _, store = cbox_store
    data_dir = tmp_path / "data"  # a copy whose exposure sends the colour far beyond 65504
    shutil.copytree(store.root, data_dir / "test32")
    man_path = data_dir / "test32" / "cbox" / "manifest.json"
    man = json.loads(man_path.read_text())
    man["exposure"] = 1e6
    man_path.write_text(json.dumps(man))
    cfg = compose_cfg(*store32_overrides(data_dir), "data.train_store.dtype=float16")
    reader = StoreReader.from_cfg(cfg)
    with caplog.at_level(logging.WARNING, logger="mcd.pack"):
        report = pack(cfg, reader, ["c4", "ref", "normal"])
    expected = sum(int((np.abs(reader.load("cbox", f, b)) > FP16_MAX).sum())
                   for f in frames_to_pack(reader, "cbox", cfg.data) for b in ("c4", "ref", "normal"))
    assert expected > 1000 and report["clamped"] == expected
    assert "beyond the float16 range clamped" in caplog.text
    assert "data.train_store.dtype=float16" in caplog.text
    ts = _open(cfg, ["c4", "ref", "normal"])
    assert ts.root.name == ".train_float16"
    assert np.load(ts.scene_path("cbox"), mmap_mode="r").dtype == np.float16
    got = ts.clip("cbox", [5, 6], None)
    for b in ("c4", "ref"):
        exact = torch.stack([torch.from_numpy(reader.load("cbox", f, b).transpose(2, 0, 1)) for f in (5, 6)])
        assert torch.isfinite(got[b]).all() and got[b].max() == FP16_MAX
        small = exact.abs() <= FP16_MAX
        assert torch.allclose(got[b][small], exact[small], rtol=1e-3, atol=1e-4)
        assert torch.equal(got[b][~small], torch.full_like(exact[~small], FP16_MAX))


def test_a_store_of_another_config_is_refused_naming_the_key(cbox_store, tmp_path):
    _, store = cbox_store
    folder = tmp_path / "ts"
    pack(_array_cfg(store.data_dir, folder), store, ["c1_in", "ref"])
    record = (folder / "cbox.json").read_text()
    for extra, key in [("data.train_store.dtype=float16", r"data\.train_store\.dtype=float16: .*packed with "
                                                           r"data\.train_store\.dtype=float32"),
                       ("data.name=other", r"data\.name=other: .*packed with data\.name=test32")]:
        cfg = _array_cfg(store.data_dir, folder, extra)
        with pytest.raises(TrainStoreError, match=key):
            pack(cfg, store, ["c1_in", "ref"])
        with pytest.raises(TrainStoreError, match=key):
            _open(cfg, ["c1_in", "ref"])
    with pytest.raises(TrainStoreError,
                       match=r"holds buffers \['c1_in', 'ref'\], this run also reads \['c4'\]"):
        pack(_array_cfg(store.data_dir, folder), store, ["c1_in", "c4", "ref"])
    assert (folder / "cbox.json").read_text() == record  # nothing was touched


def test_a_re_rendered_exr_file_makes_its_frame_stale(cbox_store, tmp_path):
    _, store = cbox_store
    data_dir = tmp_path / "data"
    shutil.copytree(store.root, data_dir / "test32")
    cfg = _array_cfg(data_dir, tmp_path / "ts")
    cfg.data.verify_checksums = "never"  # the manifest's sha256 changes below, not the file
    reader = StoreReader.from_cfg(cfg)
    pack(cfg, reader, ["c1_in", "ref"])
    man_path = data_dir / "test32" / "cbox" / "manifest.json"
    man = json.loads(man_path.read_text())
    man["files"]["0007/ref.exr"]["sha256"] = "0" * 64  # as if re-rendered
    man_path.write_text(json.dumps(man))
    reader = StoreReader.from_cfg(cfg)
    with pytest.raises(TrainStoreError, match=r"0 frame\(s\) not packed .* and 1 packed from EXR files "
                                              r"re-rendered since \(e\.g\. \[7\]\).*python -m mcd\.pack "):
        MCDDataModule(cfg, reader, ["c1_in"]).setup()
    assert pack(cfg, reader, ["c1_in", "ref"]) | {"seconds": 0} == {
        "root": str(tmp_path / "ts"), "packed": 1, "reused": 9, "clamped": 0, "clamped_total": 0,
        "seconds": 0}
    MCDDataModule(cfg, reader, ["c1_in"]).setup()


def test_a_killed_packers_temp_files_are_removed_and_the_scene_packed_whole(cbox_store, tmp_path):
    """The temp files of an atomic write (mcd/core/atomic_write.py) a killed packer left beside the scene's
    array and record are removed under the scene's lock; a neighbour scene's are not its to remove."""
    _, store = cbox_store
    folder = tmp_path / "ts"
    folder.mkdir()
    stale = [folder / ".cbox.npy.0a1b2c3d.tmp.npy", folder / ".cbox.json.4e5f6a7b.tmp.json"]
    other = folder / ".cboxes.npy.0a1b2c3d.tmp.npy"
    for p in (*stale, other):
        p.write_bytes(b"half")
    assert pack(_array_cfg(store.data_dir, folder), store, ["c1_in", "ref"])["packed"] == 10
    assert not any(p.exists() for p in stale) and other.read_bytes() == b"half"
    assert np.load(folder / "cbox.npy", mmap_mode="r").shape[0] == store.frame_count("cbox")


def test_an_exr_store_lacking_a_buffer_is_named_before_any_work(cbox_store, tmp_path):
    _, store = cbox_store
    data_dir = tmp_path / "data"
    shutil.copytree(store.root, data_dir / "test32")
    man_path = data_dir / "test32" / "cbox" / "manifest.json"
    man = json.loads(man_path.read_text())
    del man["files"]["0011/albedo.exr"]
    man_path.write_text(json.dumps(man))
    cfg = _array_cfg(data_dir, tmp_path / "ts")
    with pytest.raises(FileNotFoundError, match=r"1 buffer file\(s\) to pack were never rendered \(e\.g\. "
                                                r"frame 11 albedo\).*python -m mcd\.render .*"
                                                r"render\.buffers=\[albedo\]"):
        pack(cfg, StoreReader.from_cfg(cfg), ["albedo", "ref"])
    assert not (tmp_path / "ts").exists()


@pytest.mark.slow
def test_a_killed_pack_loses_nothing_and_resumes(tmp_path):
    """kill -9 while packing a 480x270 synthetic store of 41 frames; the pack run again packs only what was
    not recorded, and the store equals one packed in one go."""
    data_cfg = synthetic_data_cfg("killed", "synth", 480, 270, 41)
    buffers = ["c1_in", "c1", "c2", "c4", "c8", "c16", "c32", "ref", "depth", "normal", "albedo"]
    write_synthetic_store(tmp_path / "exr", data_cfg, buffers)
    spec = {"data": OmegaConf.to_container(data_cfg), "paths": {"data_dir": str(tmp_path / "exr")}}
    spec["data"]["train_store"] = {"format": "array", "dtype": "float32", "dir": str(tmp_path / "ts")}
    (tmp_path / "cfg.json").write_text(json.dumps(spec))
    script = ("import json, sys; from omegaconf import OmegaConf; from mcd.data.pack import pack; "
              "from mcd.data.store import StoreReader; cfg = OmegaConf.create(json.load(open(sys.argv[1]))); "
              "print(json.dumps(pack(cfg, StoreReader(cfg.paths.data_dir, cfg.data, overrides=[]), "
              f"{buffers!r})))")
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen([sys.executable, "-c", script, str(tmp_path / "cfg.json")], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    record = tmp_path / "ts" / "synth.json"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if record.is_file() and len(json.loads(record.read_text())["frames"]) >= 3:
            break
        time.sleep(0.02)
    assert proc.poll() is None, "the pack finished before it could be killed: " + proc.stderr.read().decode()
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    done = len(json.loads(record.read_text())["frames"])
    assert 3 <= done < 40
    again = subprocess.run([sys.executable, "-c", script, str(tmp_path / "cfg.json")], env=env,
                           capture_output=True, text=True, check=True)
    report = json.loads(again.stdout.strip().splitlines()[-1])
    assert report["reused"] == done and report["packed"] == 40 - done
    assert not list((tmp_path / "ts").glob(".*tmp*"))
    cfg = OmegaConf.create(spec)
    cfg.data.train_store.dir = str(tmp_path / "clean")
    pack(cfg, StoreReader(cfg.paths.data_dir, cfg.data, overrides=[]), buffers)
    resumed = np.load(tmp_path / "ts" / "synth.npy", mmap_mode="r")
    clean = np.load(tmp_path / "clean" / "synth.npy", mmap_mode="r")
    assert np.array_equal(resumed[1:], clean[1:])
    assert json.loads(record.read_text()) == json.loads((tmp_path / "clean" / "synth.json").read_text())


def test_mcd_run_packs_then_trains_from_the_training_store(cbox_store, tmp_path):
    """``mcd.run``'s build packs the run's buffers into the training store after rendering, and its fit trains
    on clips read from it (row A, two steps)."""
    from mcd.run import build, fit

    _, store = cbox_store
    cfg = _array_cfg(store.data_dir, tmp_path / "ts", "+experiment=A", "train.max_steps=2",
                     "train.max_minutes=null", "train.batch_size=1", "train.val_every_steps=2",
                     "train.sample_frames=[]", "trainer.enable_progress_bar=false",
                     "trainer.precision=32-true")
    job = build(cfg, tmp_path / "run")
    record = json.loads((tmp_path / "ts" / "cbox.json").read_text())
    assert sorted(record["frames"], key=int) == [str(f) for f in range(2, 12)]
    assert job.datamodule.train_store is not None and job.datamodule.train_store.root == tmp_path / "ts"
    fitted = fit(job)
    assert job.trainer.global_step == 2 and fitted.best_val_psnr is not None
    assert isinstance(job.datamodule.train_set.frames, TrainStore)

"""MCDDataModule batches (docs/architecture.md, "Batches") on a real 32x32 store."""

from __future__ import annotations

import logging

import numpy as np
import pytest
import torch

from mcd.data import MCDDataModule
from mcd.data.splits import split_frames


def test_split_first_frames_test_then_val_then_train():
    sp = split_frames(500, 0.2, 4, 5)
    assert sp["test"] == [list(range(100))]  # docs/benchmark.md: first 100 of 500 frames
    assert sp["val"][0] == [100, 101, 102, 103, 104] and len(sp["val"]) == 4
    assert len(sp["train"]) == 76 and sp["train"][0][0] == 120
    with pytest.raises(ValueError, match="frames_per_segment"):
        split_frames(8, 0.2, 1, 5)


def test_overlapping_training_clips_start_every_stride_frames():
    """``data.train_clip_stride``: tiny's 32 frames give 17 training clips per scene at stride 1, 4 without;
    validation clips never overlap, and no training clip reaches into the validation or test frames."""
    plain = split_frames(32, 0.2, 1, 5)
    assert split_frames(32, 0.2, 1, 5, 5) == plain and len(plain["train"]) == 4
    every = split_frames(32, 0.2, 1, 5, 1)
    assert every["test"] == plain["test"] and every["val"] == plain["val"] == [[6, 7, 8, 9, 10]]
    assert len(every["train"]) == 17 and every["train"][0] == [11, 12, 13, 14, 15]
    assert every["train"][-1] == [27, 28, 29, 30, 31] and all(c == list(range(c[0], c[0] + 5))
                                                               for c in every["train"])
    assert [c[0] for c in split_frames(32, 0.2, 1, 5, 2)["train"]] == list(range(11, 28, 2))
    for bad in (0, 6):
        with pytest.raises(ValueError, match="train_clip_stride"):
            split_frames(32, 0.2, 1, 5, bad)


def test_train_val_test_batches(cbox_store, caplog):
    cfg, store = cbox_store
    with caplog.at_level(logging.INFO, logger="mcd.data.datamodule"):
        dm = MCDDataModule(cfg, store, {"c4", "albedo"})
        dm.setup("fit")
    assert any("loading buffers c4,ref,albedo" in r.getMessage() for r in caplog.records)

    train = next(iter(dm.train_dataloader()))
    assert set(train) == {"c4", "ref", "albedo", "scene", "frame"}  # ref always, nothing unrequested
    assert train["c4"].shape[1:] == (5, 3, 16, 16) and train["albedo"].shape[2] == 3
    assert train["frame"].tolist()[0] == [7, 8, 9, 10, 11] and train["scene"] == ["cbox"]
    # one crop for the whole clip and every buffer: find it in the full frames
    full = torch.from_numpy(store.load("cbox", 7, "ref")).permute(2, 0, 1)
    hits = [
        (y, x)
        for y in range(17)
        for x in range(17)
        if torch.equal(full[:, y : y + 16, x : x + 16], train["ref"][0, 0])
    ]
    assert len(hits) == 1
    y, x = hits[0]
    c4_last = torch.from_numpy(store.load("cbox", 11, "c4")).permute(2, 0, 1)[:, y : y + 16, x : x + 16]
    assert torch.equal(c4_last, train["c4"][0, 4])

    val = next(iter(dm.val_dataloader()))
    assert val["ref"].shape == (1, 5, 3, 24, 24) and val["frame"].tolist() == [[2, 3, 4, 5, 6]]
    centre = torch.from_numpy(store.load("cbox", 2, "ref")).permute(2, 0, 1)[:, 4:28, 4:28]
    assert torch.equal(val["ref"][0, 0], centre)


def test_test_batches_are_whole_frames_in_order_with_window(cbox_store):
    cfg, store = cbox_store
    dm = MCDDataModule(cfg, store, {"c1_in", "motion"}, window=(2, 1))
    batches = list(dm.test_dataloader())
    assert len(batches) == 2  # 20% of 12 frames
    assert batches[0]["c1_in"].shape == (1, 4, 3, 32, 32) and batches[0]["motion"].shape == (1, 4, 2, 32, 32)
    assert batches[0]["frame"].tolist() == [[0, 0, 0, 1]] and batches[0]["reset"].tolist() == [True]
    assert batches[1]["frame"].tolist() == [[0, 0, 1, 1]] and batches[1]["reset"].tolist() == [False]
    for b in batches:
        assert all(torch.isfinite(v).all() for k, v in b.items() if k in ("c1_in", "motion", "ref"))


def test_crop_larger_than_frames_is_a_clear_error(cbox_store):
    cfg, store = cbox_store
    bad = cfg.copy()
    bad.data.train_crop = 64
    with pytest.raises(ValueError, match="train_crop=64"):
        MCDDataModule(bad, store, {"c4"}).setup("fit")


def _crop_offsets(dm: MCDDataModule, store, n: int) -> list[tuple[int, int]]:
    """Where each of ``n`` training crops of the first clip lies in its full frame."""
    full = torch.from_numpy(store.load("cbox", 7, "ref")).permute(2, 0, 1)
    offsets = []
    for _ in range(n):
        crop = dm.train_set[0]["ref"][0]
        h, w = crop.shape[-2:]
        offsets += [(y, x) for y in range(full.shape[1] - h + 1) for x in range(full.shape[2] - w + 1)
                    if torch.equal(full[:, y : y + h, x : x + w], crop)]
    return offsets


@pytest.mark.parametrize("at_edge", [0.0, 0.5, 1.0])
def test_training_crops_lie_at_frame_edges_as_often_as_asked(cbox_store, at_edge):
    """docs/training.md, "Crops at frame edges": per axis, ``data.train_crop_at_edge`` of the crops lie
    against a frame edge (either, equally); the rest are uniform over the 17 offsets of a 16 crop in 32."""
    cfg, store = cbox_store
    cfg = cfg.copy()
    cfg.data.train_crop_at_edge = at_edge
    dm = MCDDataModule(cfg, store, {"c4"})
    dm.setup("fit")
    torch.manual_seed(0)
    offsets = np.array(_crop_offsets(dm, store, 400))
    assert offsets.shape == (400, 2)
    edge = np.isin(offsets, [0, 16])
    expected = at_edge + (1 - at_edge) * 2 / 17             # snapped, or a uniform draw that lands on an edge
    assert abs(edge.mean() - expected) < 0.06
    if at_edge == 1.0:
        assert {0, 16} == set(offsets.ravel().tolist())     # both edges of both axes, nothing between
    else:
        assert len(set(offsets[:, 0].tolist())) > 10         # still spread over the frame
    # either edge equally
    assert abs((offsets == 0).sum() - (offsets == 16).sum()) < 0.15 * max(1, edge.sum())


def test_a_crop_edge_probability_outside_0_1_is_refused(cbox_store):
    cfg, store = cbox_store
    bad = cfg.copy()
    bad.data.train_crop_at_edge = 1.5
    with pytest.raises(ValueError, match=r"data\.train_crop_at_edge=1\.5: give a number from 0 to 1 \(a "
                                         r"probability"):
        MCDDataModule(bad, store, {"c4"}).setup("fit")


def test_scene_override_for_fine_tuning(cbox_store):
    cfg, store = cbox_store
    dm = MCDDataModule(cfg, store, {"c4"}, train_scenes=["cbox"], test_scenes=[])
    dm.setup("fit")
    assert len(dm.test_set) == 0 and len(dm.train_set) == 1
    assert np.isfinite(dm.train_set[0]["c4"].numpy()).all()

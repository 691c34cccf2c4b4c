"""The buffer table (mcd/data/buffers.py), the store's reader / builder split and the synthetic frames
(docs/architecture.md, "The store")."""

from __future__ import annotations

import copy

import pytest
import torch

from mcd.data import StoreBuilder, StoreReader
from mcd.data.buffers import BUFFERS, BY_NAME, CHANNELS, buffer_spp, run_buffers, uniform_buffer
from mcd.data.synthetic import synthetic_frame


def test_every_buffer_of_a_real_render_has_the_tables_channels_and_spp(cbox_store):
    """What the builder rendered (manifest) and the reader loads agree with the table, buffer by buffer (on a
    training frame; a test frame's reference has its scene's reference-quality spp, docs/data.md)."""
    cfg, built = cbox_store
    reader = StoreReader.from_cfg(cfg)
    man = reader.manifest("cbox")
    for name in BUFFERS:
        img = reader.load("cbox", 3, name)
        assert img.shape == (32, 32, CHANNELS[name]), name
        assert man["files"][f"0003/{name}.exr"]["spp"] == buffer_spp(name, cfg.data), name
        assert (img >= 0).all() or BY_NAME[name].signed, name  # sanitised: negatives only where meaningful
        assert (img == built.load("cbox", 3, name)).all(), name
    assert man["files"]["0001/ref.exr"]["spp"] == man["ref_quality"]["spp"] >= buffer_spp("ref", cfg.data)
    assert [buffer_spp(b, cfg.data) for b in ("ref", "depth", "c8", "c1_in")] == [256, 8, 8, 1]


def test_the_reader_reads_and_never_renders(cbox_store, tmp_path):
    cfg, _ = cbox_store
    reader = StoreReader.from_cfg(cfg)
    assert not hasattr(reader, "ensure") and issubclass(StoreBuilder, StoreReader)
    assert reader.frame_count("cbox") == reader.n_frames == 12
    empty = copy.deepcopy(cfg)  # (the session's cfg stays as it is)
    empty.paths.data_dir = str(tmp_path)  # an empty store: the reader names the command that renders it
    with pytest.raises(FileNotFoundError, match="python -m mcd.render"):
        StoreReader.from_cfg(empty).load("cbox", 0, "ref")
    assert not any(tmp_path.iterdir())


def test_run_buffers_add_the_reference_and_the_uniform_render_at_the_budget():
    assert uniform_buffer(4.0) == "c4"
    assert run_buffers({"c1_in", "depth"}, 8) == {"c1_in", "depth", "ref", "c8"}


def test_synthetic_frame_has_every_buffer_in_its_channels_and_range():
    x = synthetic_frame(BUFFERS, 5, 7, lead=(2, 3), seed=1, colour_scale=1e5, motion_px=2.0)
    assert list(x) == list(BUFFERS)
    for name, t in x.items():
        assert t.shape == (2, 3, CHANNELS[name], 5, 7) and t.dtype == torch.float32, name
        assert torch.isfinite(t).all(), name
    for name in ("c1_in", "c32", "ref"):
        assert x[name].min() >= 0 and x[name].max() < 1e5 and x[name].max() > 1e4
    torch.testing.assert_close(x["normal"].norm(dim=-3), torch.ones(2, 3, 5, 7))
    assert (x["depth"] > 0).all() and (x["albedo"] >= 0).all() and (x["albedo"] < 1).all()
    assert x["motion"].std() > 1 and not synthetic_frame({"motion"}, 5, 7)["motion"].any()  # still by default


def test_synthetic_frame_is_seeded_and_independent_of_the_order_of_names():
    a = synthetic_frame(["albedo", "c4", "depth"], 8, 8, seed=3)
    b = synthetic_frame(["depth", "c4", "albedo"], 8, 8, seed=3)
    assert all(torch.equal(a[k], b[k]) for k in a)
    assert not torch.equal(a["c4"], synthetic_frame(["c4", "albedo", "depth"], 8, 8, seed=4)["c4"])


def test_synthetic_frame_on_meta_has_shapes_only_and_unknown_names_fail():
    x = synthetic_frame({"c1_in", "depth"}, 1080, 1920, device="meta")
    assert x["depth"].is_meta and x["depth"].shape == (1, 1, 1080, 1920)
    with pytest.raises(ValueError, match="c3"):
        synthetic_frame({"c3"}, 4, 4)

"""Augmentations of training clips (mcd/data/augment.py, docs/training.md "Augmentations") on real renders:
every buffer of a clip moves together, motion still warps frame t-1 onto t, exposure keeps HDR finite."""

from __future__ import annotations

import itertools

import pytest
import torch
from omegaconf import OmegaConf

from mcd.config.preflight import check_run
from mcd.data import MCDDataModule
from mcd.data.augment import EXPOSURE_LIMIT, Augment, Draw, apply
from mcd.data.buffers import BUFFERS, COLOUR_BUFFERS
from mcd.data.clips import ExrClips
from mcd.models.warp import warp
from tests.conftest import compose_cfg, store32_overrides

ALL_ON = {"flips": True, "transpose": True, "channels": True, "zero_pad": 0.5, "zero_pad_max": 6,
          "exposure_stops": 2.0}


@pytest.fixture(scope="module")
def clip(cbox_store):
    """Frames 5..9 of the real 32x32 Cornell box, every buffer, a non-square 24x20 crop (so that a transpose
    shows in the shape)."""
    _, store = cbox_store
    return ExrClips(store, list(BUFFERS), cache=False).clip("cbox", [5, 6, 7, 8, 9], (4, 6, 24, 20))


def _copy(c: dict) -> dict:
    return {k: v.clone() if isinstance(v, torch.Tensor) else v for k, v in c.items()}


@pytest.mark.slow
def test_channel_permutation_moves_radiance_target_and_albedo_together(clip):
    before = _copy(clip)
    # the Cornell box's red and green walls make every channel of ref and albedo distinct
    assert not torch.equal(clip["ref"][:, 0], clip["ref"][:, 1])
    assert not torch.equal(clip["albedo"][:, 0], clip["albedo"][:, 2])
    out = apply(clip, Draw(perm=(2, 0, 1)))
    for b in (*COLOUR_BUFFERS, "albedo"):
        assert torch.equal(out[b], clip[b][:, [2, 0, 1]]), b
    for b in ("normal", "depth", "motion"):
        assert torch.equal(out[b], clip[b]), b
    for k, v in before.items():  # the input (the datamodule's cache) is untouched
        assert not isinstance(v, torch.Tensor) or torch.equal(v, clip[k])

    g = torch.Generator().manual_seed(3)
    seen = set()
    for _ in range(60):
        out = Augment(channels=True)(clip, g)
        perm = [p for p in itertools.permutations(range(3))
                if torch.equal(out["ref"], clip["ref"][:, list(p)])]
        assert len(perm) == 1
        assert torch.equal(out["albedo"], clip["albedo"][:, list(perm[0])])
        assert torch.equal(out["c1_in"], clip["c1_in"][:, list(perm[0])])
        seen.add(perm[0])
    assert len(seen) == 6


@pytest.mark.parametrize("flip_y,flip_x,transpose", list(itertools.product([False, True], repeat=3)))
def test_flipped_motion_still_warps_previous_frame_onto_current(clip, flip_y, flip_x, transpose):
    assert clip["motion"].abs().max() > 0.05  # the camera moves between these frames
    draw = Draw(flip_y=flip_y, flip_x=flip_x, transpose=transpose)
    out = apply(clip, draw)

    def move(t: torch.Tensor) -> torch.Tensor:
        t = t.flip(-2) if flip_y else t
        t = t.flip(-1) if flip_x else t
        return t.transpose(-2, -1) if transpose else t

    for b in ("ref", "c4", "albedo", "normal", "depth"):
        assert torch.equal(out[b], move(clip[b])), b
    for t in range(1, 5):
        warped = warp(clip["ref"][t - 1 : t], clip["motion"][t : t + 1])
        warped_aug = warp(out["ref"][t - 1 : t], out["motion"][t : t + 1])
        torch.testing.assert_close(warped_aug, move(warped), atol=1e-5, rtol=1e-5)
    # and the warp is worth it on this clip: it brings frame t-1 closer to frame t than no warp does
    prev, cur = out["ref"][:-1], out["ref"][1:]
    assert (warp(prev, out["motion"][1:]) - cur).abs().mean() < (prev - cur).abs().mean()


def test_exposure_scales_every_radiance_buffer_alike_and_keeps_hdr_finite(clip):
    out = apply(clip, Draw(scale=4.0))
    for b in COLOUR_BUFFERS:
        torch.testing.assert_close(out[b], clip[b] * 4.0)
    for b in ("albedo", "normal", "depth", "motion"):
        assert torch.equal(out[b], clip[b])

    hot = _copy(clip)
    hot["ref"][0, :, 3, 3] = 1e5
    hot["c1_in"][1, 0, 2, 2] = 3e38  # a firefly near float32's largest value
    out = apply(hot, Draw(scale=2.0**2))
    for b in COLOUR_BUFFERS:
        assert torch.isfinite(out[b]).all(), b
    assert float(out["c1_in"].max()) == pytest.approx(EXPOSURE_LIMIT, rel=1e-5)
    k = float(out["ref"][0, 0, 3, 3]) / 1e5  # the lowered factor, the same for every buffer
    torch.testing.assert_close(out["c4"], hot["c4"] * k)

    g = torch.Generator().manual_seed(0)
    aug = Augment(exposure_stops=2.0)
    scales = [float(aug(clip, g)["ref"].sum() / clip["ref"].sum()) for _ in range(200)]
    assert 0.25 - 1e-4 <= min(scales) < 0.4 and 2.5 < max(scales) <= 4.0 + 1e-3


def test_zero_pad_zeros_the_crop_edge_of_every_buffer(clip):
    out = apply(clip, Draw(pad=(3, 5)))
    for b, t in out.items():
        if not isinstance(t, torch.Tensor) or t.ndim != 4:
            continue
        assert (t[..., 21:, :] == 0).all() and (t[..., :, 15:] == 0).all(), b
        assert torch.equal(t[..., :21, :15], clip[b][..., :21, :15]), b
    # drawn before the flips: a flipped pad lands on the top / left
    out = apply(clip, Draw(pad=(3, 0), flip_y=True))
    assert (out["ref"][..., :3, :] == 0).all() and out["ref"][..., 3:, :].abs().sum() > 0


def test_reverse_plays_every_buffer_and_the_frame_numbers_backwards(clip):
    before = _copy(clip)
    out = apply(clip, Draw(reverse=True))
    for b, t in clip.items():
        if isinstance(t, torch.Tensor) and t.ndim == 4:
            assert torch.equal(out[b], t.flip(0)), b
    assert out["frame"].tolist() == [9, 8, 7, 6, 5] and out["scene"] == clip["scene"]
    for k, v in before.items():  # the input (the datamodule's cache) is untouched
        assert not isinstance(v, torch.Tensor) or torch.equal(v, clip[k])
    both = apply(clip, Draw(reverse=True, flip_x=True, transpose=True))
    assert torch.equal(both["ref"], clip["ref"].flip(-1).transpose(-2, -1).flip(0))


def test_reverse_is_refused_where_the_method_reads_motion(tmp_path, cbox_store):
    Augment(reverse=True).check_buffers({"c4", "albedo"})
    with pytest.raises(ValueError, match="data.augment.reverse=true"):
        Augment(reverse=True).check_buffers({"c4", "motion"})
    _, store = cbox_store
    cfg = compose_cfg(*store32_overrides(store.root.parent), "data.augment.reverse=true")
    with pytest.raises(ValueError, match="data.augment.reverse=true"):
        MCDDataModule(cfg, store, {"c4", "motion"}).setup("fit")


def test_draws_follow_their_switches():
    g = torch.Generator().manual_seed(1)
    aug = Augment(**ALL_ON)
    draws = [aug.sample(g) for _ in range(400)]
    for name in ("flip_y", "flip_x", "transpose"):
        share = sum(getattr(d, name) for d in draws) / len(draws)
        assert 0.4 < share < 0.6, name
    padded = [d.pad for d in draws if d.pad != (0, 0)]
    assert 0.35 < len(padded) / len(draws) < 0.6 and max(max(p) for p in padded) <= 5
    assert len({d.perm for d in draws}) == 6
    none = Augment(flips=True).sample(g)
    assert none.perm is None and none.scale == 1.0 and none.pad == (0, 0) and not none.transpose
    assert not any(d.reverse for d in draws)
    rev = [Augment(reverse=True).sample(g).reverse for _ in range(400)]
    assert 0.4 < sum(rev) / len(rev) < 0.6
    # drawn last: a run that turns reverse on draws the other augmentations of its first clip as before
    first = Augment(**ALL_ON).sample(torch.Generator().manual_seed(5))
    again = Augment(**ALL_ON, reverse=True).sample(torch.Generator().manual_seed(5))
    assert Draw(**{**again.__dict__, "reverse": False}) == first


def _data(**augment):
    return OmegaConf.create({"train_crop": 16, "augment": augment})


def test_config_errors_name_the_key():
    assert Augment.from_cfg(OmegaConf.create({"train_crop": 16})) is None
    assert Augment.from_cfg(_data(flips=False)) is None
    assert Augment.from_cfg(_data(**ALL_ON)) == Augment(**ALL_ON)
    for bad, key in [({"flip": True}, "unknown key"), ({"zero_pad": 1.5}, "data.augment.zero_pad="),
                     ({"exposure_stops": -1.0}, "data.augment.exposure_stops"),
                     ({"zero_pad": 0.5, "zero_pad_max": 40}, "data.augment.zero_pad_max"),
                     ({"channels": "yes"}, "data.augment.channels"),
                     ({"reverse": 1}, "data.augment.reverse")]:
        with pytest.raises(ValueError, match=key):
            Augment.from_cfg(_data(**bad))
    with pytest.raises(ValueError, match="data.augment.exposure_stops"):  # mcd.run preflight, before renders
        check_run(compose_cfg("data.augment.exposure_stops=-2"))


def test_datamodule_augments_training_clips_only(tmp_path, cbox_store):
    cfg_plain, store = cbox_store
    overrides = [f"data.augment.{k}={v}" for k, v in ALL_ON.items()]
    cfg = compose_cfg(*store32_overrides(store.root.parent), *overrides)
    dm = MCDDataModule(cfg, store, {"c4", "albedo", "motion"})
    dm.setup("fit")
    assert dm.train_set.augment == Augment(**ALL_ON) and dm.val_set.augment is None
    plain = MCDDataModule(cfg_plain, store, {"c4", "albedo", "motion"})
    plain.setup("fit")
    assert plain.train_set.augment is None
    torch.manual_seed(0)
    batches = [next(iter(dm.train_dataloader())) for _ in range(8)]
    full = torch.from_numpy(store.load("cbox", 7, "ref")).permute(2, 0, 1)
    crops = [full[:, y : y + 16, x : x + 16] for y in range(17) for x in range(17)]
    assert not all(any(torch.equal(b["ref"][0, 0], c) for c in crops) for b in batches)  # augmented
    val = next(iter(dm.val_dataloader()))
    centre = torch.from_numpy(store.load("cbox", 2, "ref")).permute(2, 0, 1)[:, 4:28, 4:28]
    assert torch.equal(val["ref"][0, 0], centre)  # validation clips are not augmented
    with pytest.raises(ValueError, match="data.augment.zero_pad="):
        MCDDataModule(compose_cfg(*store32_overrides(store.root.parent), "data.augment.zero_pad=2"),
                      store, {"c4"}).setup("fit")

"""The output bound (``method.output_bound``, mcd/models/output_bound.py; docs/method.md "Output"): on
kitchenette-like frames (a real 32x32 Cornell-box render darkened 1000x, a few 1e4 fireflies, a reference
near zero) every bundled checkpoint and a freshly built model of every learned method keeps every output
pixel finite and within the bound, and the bundles beat the noisy input's rMSE there; on the ordinary
frames the bound leaves the bundles' outputs as they were."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from omegaconf import open_dict

from mcd.config.compose import compose
from mcd.core.metrics import psnr, rmse
from mcd.data.buffers import BUFFERS, COLOUR_BUFFERS
from mcd.data.clips import ExrClips
from mcd.data.datamodule import SequenceDataset
from mcd.denoise import weights
from mcd.lit.test_recorder import hwc
from mcd.models import build
from mcd.models.output_bound import clamp_output, output_bound
from mcd.models.output_steps import denoised_render

BUNDLES = weights.bundled_names()
LEARNED = ("F", "unet", "rae", "fastdvdnet", "dasr", "ntasad")
#: Darkening of the hard frames and their fireflies (linear, after the store's exposure: frame mean 0.5).
DARK, FIREFLY = 1e-3, 1e4
FIREFLIES = ((3, 5), (17, 22), (28, 9), (11, 30))
#: On ordinary frames the bounded and the free outputs agree to this PSNR (dB, display images) at least.
ORDINARY_DB = 60.0
#: ... and the bound changes at most this share of output values.
ORDINARY_SHARE = 1e-3


def _frames(cbox_store, window: tuple[int, int]) -> list[dict[str, torch.Tensor]]:
    """The store's two cbox test frames as a model reads them (every buffer, ``window`` of neighbours)."""
    _, store = cbox_store
    seq = SequenceDataset(ExrClips(store, list(BUFFERS), cache=False), [("cbox", [0, 1])], window)
    out = []
    for i in range(len(seq)):
        item = seq[i]
        x = {k: v[None] for k, v in item.items() if isinstance(v, torch.Tensor) and v.ndim == 4}
        out.append({k: v[:, window[0]] if window == (0, 0) else v for k, v in x.items()})
    return out


def _hard(x: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
    """``x`` kitchenette-like: every colour buffer (the reference too) times :data:`DARK`, and the noisy
    ones with :data:`FIREFLY` in every channel at :data:`FIREFLIES`."""
    out = dict(x)
    for k in COLOUR_BUFFERS:
        if k in out:
            v = out[k] * DARK
            if k != "ref":
                for y, xx in FIREFLIES:
                    v[..., y, xx] = FIREFLY
            out[k] = v
    return out


def _run(model: torch.nn.Module, frames: list[dict[str, torch.Tensor]], budget: float):
    """``(output, render, ref)`` per frame of ``model`` (reset at the first), as the test does."""
    model.reset()
    past = int(model.window[0])
    rows = []
    with torch.inference_mode():
        for x in frames:
            ref = x["ref"][:, past] if x["ref"].dim() == 5 else x["ref"]
            torch.manual_seed(0)
            out = model({**x, "ref": None})
            rows.append((out["output"].float(), denoised_render(out, x, budget, past).float(), ref))
    return rows


def _check_bounded(rows, normal_key: list[torch.Tensor]) -> None:
    for (out, render, _), normal in zip(rows, normal_key, strict=True):
        assert torch.isfinite(out).all()
        miss = (normal == 0).all(dim=1, keepdim=True)     # pass_misses keeps the render's value there
        bound = output_bound(render)
        assert ((out >= 0) & ((out <= bound * (1 + 1e-5)) | miss)).all(), float((out - bound).max())


def _normals(frames: list[dict[str, torch.Tensor]], past: int) -> list[torch.Tensor]:
    return [x["normal"][:, past] if x["normal"].dim() == 5 else x["normal"] for x in frames]


@pytest.mark.parametrize("name", BUNDLES)
def test_bundles_stay_bounded_and_beat_the_input_on_a_dark_frame_with_fireflies(cbox_store, name):
    loaded = weights.load(name)
    model, budget = loaded.model, float(loaded.cfg.budget)
    frames = [_hard(x) for x in _frames(cbox_store, tuple(model.window))]
    rows = _run(model, frames, budget)
    _check_bounded(rows, _normals(frames, int(model.window[0])))
    for out, _, ref in rows:
        noisy = frames[0][f"c{int(budget)}"]
        assert rmse(hwc(out[0]), hwc(ref[0])) < rmse(hwc(noisy[0]), hwc(ref[0]))


@pytest.mark.parametrize("experiment", LEARNED)
def test_a_fresh_model_of_every_learned_method_stays_bounded_on_the_hard_frames(cbox_store, experiment):
    cfg = compose([f"+experiment={experiment}", "capacity=cpu"])
    assert cfg.method.output_bound is True
    torch.manual_seed(0)
    model = build(cfg).eval()
    frames = [_hard(x) for x in _frames(cbox_store, tuple(model.window))]
    rows = _run(model, frames, float(cfg.budget))
    _check_bounded(rows, _normals(frames, int(model.window[0])))


@pytest.mark.parametrize("name", BUNDLES)
def test_on_ordinary_frames_the_bound_leaves_the_bundles_outputs_as_they_were(cbox_store, name):
    loaded = weights.load(name)
    cfg = loaded.cfg.copy()
    with open_dict(cfg):
        cfg.method.output_bound = False
    free = build(cfg).eval()
    free.load_state_dict(loaded.model.state_dict())
    frames = _frames(cbox_store, tuple(loaded.model.window))
    budget = float(loaded.cfg.budget)
    rows = zip(_run(loaded.model, frames, budget), _run(free, frames, budget), strict=True)
    for (a, _, _), (b, _, _) in rows:
        changed = float(((a - b).abs() > 1e-6 * (b.abs() + 1e-6)).float().mean())
        assert changed <= ORDINARY_SHARE, changed
        assert psnr(hwc(a[0]), hwc(b[0])) > ORDINARY_DB


def test_a_lone_firefly_sets_no_bound_but_a_two_pixel_light_does():
    """A lone 1e4 pixel on black is bounded by the frame's floor (its 99% quantile: the 3.0 patch, 10% of
    the frame), a light of two pixels by twice its own value plus the floor, the patch by twice its level plus
    the floor; far from everything, the floor. NaN and Inf become the render's 3x3 mean, negatives 0."""
    render = torch.zeros(1, 3, 32, 32)
    render[..., 2:12, 2:12] = 3.0
    render[..., 16, 16] = 1e4
    render[..., 26, 25:27] = 500.0
    bound = output_bound(render)
    assert bound[0, 0, 16, 16] == pytest.approx(3.0)
    assert bound[0, 0, 26, 25] == pytest.approx(2 * 500 + 3.0) == bound[0, 0, 29, 22]
    assert bound[0, 0, 6, 6] == pytest.approx(2 * 3.0 + 3.0)
    assert bound[0, 0, 2, 30] == pytest.approx(3.0)
    out = torch.full((1, 3, 32, 32), 1e6)
    out[0, 0, 6, 6], out[0, 1, 6, 6], out[0, 2, 6, 6] = float("nan"), float("inf"), -5.0
    clamped = clamp_output(out, render)
    assert torch.isfinite(clamped).all() and (clamped >= 0).all() and (clamped <= bound).all()
    assert clamped[0, 0, 6, 6] == pytest.approx(3.0) and clamped[0, 2, 6, 6] == 0.0


@pytest.mark.slow
def test_the_bound_is_off_in_training_and_a_bad_value_is_refused():
    """In training the output is the network's own, bound or not (a clamp would zero its pixels'
    gradients); a value that is not a boolean is refused naming the key; OIDN and the noisy input, without
    weights, are not bounded unless asked."""
    from mcd.models.complexity import dummy_batch
    from mcd.models.output_steps import output_bound_on

    cfg = compose(["+experiment=unet", "capacity=cpu", "method.mean_match=false"])
    torch.manual_seed(0)
    bounded = build(cfg).train()
    cfg.method.output_bound = False
    torch.manual_seed(0)
    free = build(cfg).train()
    x = dummy_batch(bounded, 16, 16, "cpu")
    x = {k: v * 1e4 if k in COLOUR_BUFFERS and v is not None else v for k, v in x.items()}
    with torch.no_grad():
        last = [m for m in bounded.modules() if isinstance(m, torch.nn.Conv2d)][-1]
        last.bias.fill_(50.0)   # an output far above anything in the input
        free.load_state_dict(bounded.state_dict())
        assert torch.equal(bounded(x)["output"], free(x)["output"])
        bounded.eval()
        assert (bounded(x)["output"] <= output_bound(x["c4"])).all()
    cfg.method.output_bound = "yes"
    with pytest.raises(ValueError, match="method.output_bound='yes'"):
        build(cfg)
    assert not output_bound_on(compose(["+experiment=noisy"]).method)
    assert np.all([output_bound_on(compose([f"+experiment={e}"]).method) for e in LEARNED])

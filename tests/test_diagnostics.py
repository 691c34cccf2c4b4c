"""Diagnostic switches for the F - NTASAD gap (docs/method.md "Diagnostics", docs/baselines.md "NTASAD's
diagnostics"): each changes what the network reads, shown by a real forward pass over two consecutive frames
of a real 32x32 Cornell-box render (the camera moves, so the motion vectors are not zero), and each is refused
before any work where it does not apply."""

from __future__ import annotations

import json
import time

import pytest
import torch

from mcd.config.compose import compose
from mcd.config.preflight import check_augment, check_motion, check_run
from mcd.data import BUFFERS
from mcd.models import build
from mcd.models.inputs import compress
from mcd.models.warp import warp
from tests.conftest import compose_cfg, mcd_run, store32_overrides

CROPS = ["data.train_crop=32", "data.val_crop=32", "train.batch_size=1"]


def frames(store, n: int = 2) -> list[dict[str, torch.Tensor]]:
    """The first ``n`` frames of cbox as model inputs ``[1, C, 32, 32]`` (every stored buffer)."""
    out = []
    for f in range(n):
        out.append({b: torch.from_numpy(store.load("cbox", f, b)).permute(2, 0, 1)[None] for b in BUFFERS})
    return out


def model_of(cbox_store, *overrides: str):
    cfg = compose_cfg(*store32_overrides(cbox_store[1].data_dir), *overrides)
    torch.manual_seed(0)
    return build(cfg).eval()


def inputs_of(model, module: torch.nn.Module, xs: list[dict]) -> list[torch.Tensor]:
    """What ``module`` (a part of ``model``) reads on each of the frames ``xs``, run in sequence."""
    seen: list[torch.Tensor] = []
    handle = module.register_forward_pre_hook(lambda _m, args: seen.append(args[0].detach().clone()))
    model.reset()
    with torch.no_grad():
        outs = [model(x) for x in xs]
    handle.remove()
    return seen, outs


def kept_after_first_frame(model, xs: list[dict]) -> torch.Tensor:
    """The output ``model`` keeps for the next frame after the first of ``xs`` (before the output steps)."""
    model.reset()
    with torch.no_grad():
        model(xs[0])
    return model.prev.clone()


def test_the_motion_vectors_of_the_test_frames_are_not_zero(cbox_store):
    (_, x1) = frames(cbox_store[1])
    assert x1["motion"].abs().max() > 0.05


def test_ntasad_without_its_warp_reads_zero_motion_and_its_output_unwarped(cbox_store):
    xs = frames(cbox_store[1])
    on = model_of(cbox_store, "+experiment=ntasad")
    off = model_of(cbox_store, "+experiment=ntasad_no_warp")
    off.load_state_dict(on.state_dict())
    assert "motion" in on.required_buffers() and "motion" not in off.required_buffers()
    s_on, _ = inputs_of(on, on.sampler, xs)
    s_off, _ = inputs_of(off, off.sampler, xs)
    motion = slice(7, 9)  # sampler input: g (7), motion (2), grey albedo, grey previous
    assert s_on[1][:, motion].abs().max() > 0 and s_off[1][:, motion].abs().max() == 0
    d_on, outs_on = inputs_of(on, on.denoiser, xs)
    d_off, outs_off = inputs_of(off, off.denoiser, xs)
    prev = slice(10, 13)  # denoiser input: i (3), g (7), previous output (3)
    m = on.denoiser_margin  # outside training the denoiser reads the frame reflected by m (models/margin.py)
    frame = (slice(None), prev, slice(m, m + 32), slice(m, m + 32))
    assert torch.equal(d_on[0][:, prev], d_off[0][:, prev])  # first frame: the uniform render in both
    assert torch.allclose(d_off[1][frame], compress(kept_after_first_frame(off, xs)))
    kept = kept_after_first_frame(on, xs)
    assert torch.allclose(d_on[1][frame], compress(warp(kept, xs[1]["motion"])))
    assert not torch.allclose(d_on[1][:, prev], d_off[1][:, prev])
    assert not torch.allclose(outs_on[1]["output"], outs_off[1]["output"])


def test_ntasad_without_its_previous_output_reads_zeros_in_its_place(cbox_store):
    xs = frames(cbox_store[1])
    on = model_of(cbox_store, "+experiment=ntasad")
    off = model_of(cbox_store, "+experiment=ntasad_no_previous")
    off.load_state_dict(on.state_dict())
    d_off, outs_off = inputs_of(off, off.denoiser, xs)
    d_on, outs_on = inputs_of(on, on.denoiser, xs)
    assert all(d[:, 10:13].abs().max() == 0 for d in d_off)
    assert all(d[:, 10:13].abs().max() > 0 for d in d_on)
    assert not torch.allclose(outs_on[1]["output"], outs_off[1]["output"])


def test_warp_previous_feeds_f_d_its_previous_output_warped(cbox_store):
    xs = frames(cbox_store[1])
    plain = model_of(cbox_store, "+experiment=F")
    warped = model_of(cbox_store, "+experiment=F_warp_previous")
    assert "motion" in warped.required_buffers() and "motion" not in plain.required_buffers()
    assert warped.temporal_state
    seen, _ = inputs_of(warped, warped.denoiser, xs)
    base, _ = inputs_of(plain, plain.denoiser, xs)
    assert seen[0].shape[1] == base[0].shape[1] + 3
    # F_d runs on its input reflected by the margin outside training: the frame is its centre
    m = warped.denoiser_margin
    inner = (slice(None), slice(None), slice(m, m + 32), slice(m, m + 32))
    assert torch.equal(seen[0][inner][:, -3:], seen[0][inner][:, :3])  # frame 0: its own colour input
    # frame 1: F_d's frame-0 output (network range, before the output steps) warped by frame 1's motion
    y0 = kept_after_first_frame(warped, xs)
    assert torch.allclose(seen[1][inner][:, -3:], warp(y0, xs[1]["motion"]), atol=1e-6)
    # the motion vectors change what it reads and its output
    still = {**xs[1], "motion": torch.zeros_like(xs[1]["motion"])}
    with torch.no_grad():
        warped.reset()
        warped(xs[0])
        moved = warped(xs[1])["output"]
        warped.reset()
        warped(xs[0])
        unmoved = warped(still)["output"]
    assert not torch.allclose(moved, unmoved)


def test_f_without_sa_is_row_e():
    e, f = compose(["+experiment=E"]), compose(["+experiment=F", "method.SA=false"])
    assert e.method.SA is False and e.method == f.method


@pytest.mark.parametrize(("overrides", "message"), [
    (["+experiment=rae", "+method.warp_previous=true"], r"method\.warp_previous: method rae has no such"),
    (["+experiment=ntasad", "+method.warp_previous=true"], r"method\.warp_previous: method ntasad has no"),
    (["+experiment=F", "+method.warp=false"], r"method\.warp: method two_stage has no such input.*ntasad"),
    (["+experiment=rae", "+method.previous_output=false"], r"method\.previous_output: method rae"),
    (["+experiment=F", "method.warp_previous=maybe"], r"method\.warp_previous='maybe': give true or false"),
])
def test_a_diagnostic_switch_on_a_method_without_that_input_is_refused(overrides, message):
    with pytest.raises(ValueError, match=message):
        check_run(compose(overrides))


def test_warp_previous_is_refused_where_the_training_clips_cannot_hold_motion(tmp_path):
    data = f"paths.data_dir={tmp_path}"
    cfg = compose(["+experiment=F_warp_previous", "data.augment.reverse=true", data])
    buffers = build(cfg).required_buffers()
    with pytest.raises(ValueError, match=r"data\.augment\.reverse=true: this method reads the motion buffer"):
        check_augment(cfg, buffers)
    cfg = compose(["+experiment=F_warp_previous", "data.train_store.format=array", data])
    packed = tmp_path / "tiny" / ".train_float32"
    packed.mkdir(parents=True)
    (packed / "store.json").write_text(json.dumps({"channels": {"c1_in": [0, 3], "ref": [3, 6]}}))
    with pytest.raises(ValueError, match=r"warp_previous=true reads the motion buffer, and the training "
                                         r"store .*\.train_float32 holds \['c1_in', 'ref'\]"):
        check_motion(cfg, buffers)
    check_motion(cfg, build(compose(["+experiment=F"])).required_buffers())  # F reads no motion


@pytest.mark.slow
def test_mcd_run_refuses_warp_previous_with_reversed_clips_before_any_render(tmp_path):
    res = mcd_run("+experiment=F_warp_previous", "data.augment.reverse=true",
                  f"paths.data_dir={tmp_path / 'data'}", f"hydra.run.dir={tmp_path / 'run'}")
    assert res.returncode != 0
    assert "data.augment.reverse=true: this method reads the motion buffer" in res.stderr + res.stdout
    assert not any((tmp_path / "data").rglob("*.exr"))


@pytest.mark.slow
@pytest.mark.parametrize("experiment", ["F_warp_previous", "ntasad_no_warp", "ntasad_no_previous"])
def test_each_diagnostic_trains_and_tests(cbox_store, tmp_path, experiment):
    from mcd.run import train_and_test

    cfg = compose_cfg(*store32_overrides(cbox_store[1].data_dir), *CROPS, f"+experiment={experiment}",
                      "train.max_steps=2", "train.max_minutes=null", "train.val_every_steps=2",
                      "train.sample_frames=[]", "trainer.enable_progress_bar=false")
    train_and_test(cfg, tmp_path, {}, time.perf_counter())
    m = json.loads((tmp_path / "metrics.json").read_text())
    assert m["experiment"] == experiment and m["train_steps"] == 2 and m["psnr"] > 0

"""``python -m mcd.plan`` (mcd/plan.py, docs/scale.md "Plan"): the counts of a profile, the
measured figures; the line of counts ``mcd.run`` / ``mcd.render`` log before their work (no render, no model);
the render's progress lines."""

from __future__ import annotations

import json
import logging
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mcd
from mcd.data import StoreBuilder
from mcd.data.pack import pack
from mcd.lit.module import DenoiseModule
from mcd.lit.workload import _gb, _range, derive, train_step, work
from mcd.losses import build_loss
from mcd.models import build
from mcd.plan import lines, main, plan
from tests.conftest import compose_cfg, store32_overrides


def test_paper_counts_match_the_protocols_arithmetic():
    """Row F on the paper profile: 11 stored buffers (31 channels + motion's depth), 19 scenes x 500 frames at
    1080p; 16 training scenes x (500 - 100 test) packed frames, each 17 x 30 tiles of 64 (1088 x 1920, the
    last tile row padded); 76 training clips per scene."""
    wk = work(compose_cfg("data=paper", "capacity=paper", "train=paper"))
    pixels, padded = 1920 * 1080, 1920 * 1088
    channels = 3 * 8 + 1 + 3 + 3  # c1_in, c1..c32, ref; depth, normal, albedo
    assert wk["exr_frame_bytes"] == pixels * channels * 4
    assert wk["exr_bytes"] == pixels * channels * 4 * 500 * 19
    assert wk["train_store_frames"] == 16 * 400 and wk["train_channels"] == channels
    assert wk["train_store_frame_bytes"] == {"float32": padded * channels * 4,
                                             "float16": padded * channels * 2}
    assert wk["train_store_bytes"] == {"float32": 6400 * channels * padded * 4,
                                       "float16": 6400 * channels * padded * 2}
    # spp per pixel per scene: the uniform stack and c1_in every frame, references at 2048 (train) or up to
    # 16384 (the 100 test frames), the pilot's 2048, G-buffers at 64
    stack = 1 + (1 + 2 + 4 + 8 + 16 + 32)
    assert wk["spp_per_scene"] == (500 * (stack + 2048 + 64) + 2048,
                                   500 * (stack + 64) + 400 * 2048 + 100 * 16384 + 2048)
    assert wk["samples"] == tuple(s * pixels * 19 for s in wk["spp_per_scene"])
    assert wk["train_clips"] == 16 * 76 and wk["steps_per_epoch"] == 152 and wk["run_steps"] == 300 * 152


@pytest.mark.parametrize("dtype", ["float32", "float16"])
def test_the_training_store_bytes_are_what_the_pack_writes(cbox_store, tmp_path, dtype):
    """The plan's bytes per packed frame are those of a real packed store (32x32 frames: one 64x64 tile each,
    three quarters padding), and its frame count is the frames the pack wrote."""
    _, store = cbox_store
    cfg = compose_cfg(*store32_overrides(store.data_dir), "data.train_store.format=array",
                      f"data.train_store.dtype={dtype}", f"data.train_store.dir={tmp_path / 'ts'}")
    wk = work(cfg)
    report = pack(cfg, store, wk["train_buffers"])
    array = tmp_path / "ts" / "cbox.npy"
    mm = np.load(array, mmap_mode="r")  # (every frame, tiles_y, tiles_x, channels, 64, 64): test frames holes
    on_disk_per_frame = (array.stat().st_size - mm.offset) / mm.shape[0]
    assert wk["train_store_frame_bytes"][dtype] == on_disk_per_frame == 64 * 64 * wk["train_channels"] * (
        4 if dtype == "float32" else 2)
    assert report["packed"] == wk["train_store_frames"]
    assert wk["train_store_bytes"][dtype] == report["packed"] * on_disk_per_frame


@pytest.mark.slow
def test_plan_prints_every_figure_on_a_tiny_profile(tmp_path, capsys):
    """The whole plan on a 32x32 Cornell box profile: a real pilot render, training step and loader rate."""
    main(compose_cfg(*store32_overrides(tmp_path), "plan.pilot_scale=1", "plan.pilot_frames=2"))
    out = capsys.readouterr().out
    pilot = next(line for line in out.splitlines() if line.startswith("pilot render"))
    cbox = next(line for line in out.splitlines() if line.startswith("  cbox: "))
    assert "2 frame(s)" in pilot and "(frames: " in cbox  # each frame's seconds: a recompile would show
    for start in ("plan for profile test32", "EXR store", "training store", "samples:", "training:",
                  "pilot render: 1 scene(s) at 32x32", "  cbox: ", "render time here",
                  "render on the reference GPU",
                  "training step memory", "training step time", "loader: a GPU needs", "total: plan test32",
                  "(measured here"):
        assert any(line.startswith(start) for line in out.splitlines()), (start, out)
    assert not (tmp_path / "test32").exists()  # nothing rendered into the store



def made_pilot(wk: dict, per_sample: float, per_call: float, variant: str, per_scene: float = 0.0) -> dict:
    """A pilot as :func:`mcd.lit.workload.pilot_render` returns it: every scene of ``wk`` at these costs."""
    c = {"s_per_sample": per_sample, "s_per_call": per_call, "s_per_scene": per_scene}
    return {"scene": wk["scenes"][0], "variant": variant, "scenes": dict.fromkeys(wk["scenes"], c),
            "skipped": []}


def test_each_scene_costs_its_own_samples_calls_and_load_and_a_missing_one_the_mean():
    """The render time sums the scenes at their own costs: a scene ten times dearer per sample weighs ten
    times, its load counts once, and a scene the pilot could not load costs the mean of those it did."""
    from mcd.lit.workload import render_seconds

    wk = {"scenes": ["cheap", "dear", "absent"], "spp_per_scene": (100, 200), "width": 10, "height": 10,
          "render_calls_per_scene": 10}
    pilot = {"scenes": {"cheap": {"s_per_sample": 1e-6, "s_per_call": 0.1, "s_per_scene": 2.0},
                        "dear": {"s_per_sample": 1e-5, "s_per_call": 0.3, "s_per_scene": 4.0}}}
    # per scene: spp x 100 pixels x s/sample + 10 calls x s/call + s/scene, at 100 and at 200 spp
    cheap, dear, mean = (0.01 + 1.0 + 2.0, 0.02 + 1.0 + 2.0), (0.1 + 3.0 + 4.0, 0.2 + 3.0 + 4.0), \
        (0.055 + 2.0 + 3.0, 0.11 + 2.0 + 3.0)
    want = tuple(c + d + m for c, d, m in zip(cheap, dear, mean, strict=True))
    assert render_seconds(wk, pilot) == pytest.approx(want)


def test_the_step_time_and_memory_are_the_measured_batchs(tmp_path):
    """The step's figures are those of one optimiser step of the whole batch as measured: on a GPU its
    seconds are the GPU step; on CPU they are divided by the render ratio; the memory adds the state's."""
    wk = work(compose_cfg("data=paper", "capacity=paper", "train=paper", f"paths.data_dir={tmp_path}"))
    pilot = made_pilot(wk, 3e-8, 0.0, "cuda_ad_rgb")
    step = {"device": "cuda", "seconds": 0.9, "memory_mb": 6000.0, "state_mb": 20.0}
    measured = derive(wk, pilot, step, None)
    assert measured["gpu_step_s"] == 0.9 and measured["step_memory_mb"] == 6020.0
    assert measured["train_gpu_hours"] == pytest.approx(wk["run_steps"] * 0.9 / 3600)
    cpu = derive(wk, made_pilot(wk, 3e-7, 0.0, "llvm_ad_rgb"),
                 {**step, "device": "cpu"}, None)
    assert cpu["gpu_step_s"] == pytest.approx(0.9 / cpu["ratio"]) and cpu["step_memory_mb"] == 6020.0


@pytest.mark.slow
@pytest.mark.parametrize(("precision", "channels_last", "autocast"),
                         [("bf16-mixed", True, "bfloat16"), ("32-true", False, None)])
def test_the_planned_step_is_the_step_the_run_trains(tmp_path, precision, channels_last, autocast):
    """:func:`train_step` times the training module's own step as configured: ``train.batch_size`` clips of
    ``data.clip_len`` frames at the crop, in ``trainer.precision`` and the layout of ``train.channels_last``,
    the frames run as :meth:`DenoiseModule.clip_plan` says (those before the returned ones through
    ``TwoStage.advance``, not the whole forward; gradient from its first frame with gradient): read by a
    hook on the real model F, not from the config."""
    cfg = compose_cfg(*store32_overrides(tmp_path), "+experiment=F", f"trainer.precision={precision}",
                      f"train.channels_last={channels_last}", "train.batch_size=3", "data.clip_len=4",
                      "train.grad_frames=1")
    step = train_step(cfg, step_crop=16)
    assert step["precision"] == precision and step["batch"] == step["measured_batch"] == 3
    assert step["measured_crops"] == [16] and step["seconds"] > 0  # the crop itself
    assert step["observed"]["channels_last"] is channels_last
    first, grad_from, returned = DenoiseModule(cfg, build(cfg), build_loss(cfg)).clip_plan(4)
    assert returned > first  # F carries state: frames before the loss's go through advance
    calls = step["observed"]["calls"]  # the last timed step's, at the measured crop 16
    assert [c["grad"] for c in calls] == [t >= grad_from for t in range(returned, 4)]
    assert all(c["batch"] == 3 and c["size"] == [16, 16] and c["autocast"] == autocast for c in calls)


@pytest.mark.slow
def test_one_clip_measured_is_scaled_to_the_batch(tmp_path):
    """``batch=1`` measures one clip and scales seconds and memory to ``train.batch_size``; a crop above
    ``step_crop`` is measured at it and half of it."""
    cfg = compose_cfg(*store32_overrides(tmp_path), "+experiment=A", "train.batch_size=3")
    step = train_step(cfg, step_crop=12, batch=1)
    assert step["batch"] == 3 and step["measured_batch"] == 1 and step["measured_crops"] == [8, 12]
    assert {(c["batch"], tuple(c["size"])) for c in step["observed"]["calls"]} == {(1, (12, 12))}


def test_a_profile_too_short_to_train_on_is_planned_without_training(tmp_path, capsys):
    """A profile that only renders and tests (a transfer run's held-out scene) gets a plan whose training line
    says why there is none, naming the keys; ``mcd.render`` of it is not refused by the plan."""
    cfg = compose_cfg(*store32_overrides(tmp_path), "data.segments=1", "data.frames_per_segment=3")
    wk = work(cfg)
    assert wk["train_clips"] == 0 and wk["train_store_bytes"]["float32"] == 0 and wk["exr_bytes"] > 0
    assert "data.frames_per_segment" in wk["train_error"]
    main(compose_cfg(*store32_overrides(tmp_path), "data.segments=1", "data.frames_per_segment=3",
                     "plan.measure=false"))
    assert "training: none on this profile: a 3-frame sequence" in capsys.readouterr().out


#: announce in a fresh interpreter: its line, and which of the modules a pilot render (Mitsuba, Dr.Jit, the
#: renderer) or a model build (the method registry, the training module) needs it imported
ANNOUNCE = """
import json, sys
from mcd.config.compose import compose
from mcd.lit.workload import announce
cfg = compose(json.loads(sys.argv[1]))
line = announce(cfg, sys.argv[2], json.loads(sys.argv[3]), train=sys.argv[2] == "mcd.run", share=0.25)
heavy = [m for m in sys.modules if m.split(".")[0] in ("mitsuba", "drjit")
         or m in ("mcd.data.renderer", "mcd.data.mitsuba_env", "mcd.models.registry", "mcd.lit.module")]
print(json.dumps({"line": line, "heavy": sorted(heavy)}))
"""


@pytest.mark.parametrize("what", ["mcd.run", "mcd.render"])
@pytest.mark.slow
def test_announce_counts_without_rendering_or_building_a_model(tmp_path, what):
    """The paper profile (which once made the announce render a pilot and build a second model to time a
    step): in a fresh interpreter the announce imports neither Mitsuba nor the renderer nor the method
    registry, and its figures are those ``python -m mcd.plan plan.measure=false`` prints for the config."""
    overrides = ["data=paper", "capacity=paper", "train=paper", f"paths.data_dir={tmp_path}"]
    cfg = compose_cfg(*overrides)
    wk = work(cfg)
    done = subprocess.run([sys.executable, "-c", ANNOUNCE, json.dumps(overrides), what,
                           json.dumps(wk["train_buffers"])], capture_output=True, text=True, check=True,
                          env={**os.environ, "PYTHONPATH": str(Path(mcd.__file__).parents[1])})
    out = json.loads(done.stdout.splitlines()[-1])
    assert out["heavy"] == []
    line, plan_text = out["line"], "\n".join(lines(plan(cfg, measure=False)))
    figures = ["19 scenes x 500 frames at 1920x1080", _gb(wk["exr_bytes"]), _range(*wk["samples"]),
               ",".join(wk["render_buffers"])]
    if what == "mcd.run":
        figures += [_gb(wk["train_store_bytes"]["float32"]), f"{wk['run_steps']} steps"]
    else:
        assert "training store" not in line
    for figure in figures:
        assert figure in line and figure in plan_text, (figure, line, plan_text)
    assert line.startswith(f"{what}: profile paper: ") and "0.25 of them in this process" in line
    assert line.endswith("python -m mcd.plan measures them")


def test_run_and_render_log_the_counts_before_their_work(cbox_store, tmp_path, caplog):
    """``mcd.render`` and ``mcd.run``'s build on a complete store: the announce's line comes before the store
    is checked, nothing is rendered, and the run's line has its steps and training store."""
    from mcd.render import main as render
    from mcd.run import build

    cfg, store = cbox_store
    caplog.set_level(logging.INFO)
    report = render(cfg)
    messages = [r.getMessage() for r in caplog.records]
    (line,) = [m for m in messages if m.startswith("mcd.render: profile test32: 1 scenes x 12 frames")]
    assert messages.index(line) < min(i for i, m in enumerate(messages) if m.startswith("rendering profile"))
    assert report["msamples"] == 0 and not any(report["rendered"].values())
    caplog.clear()
    run_cfg = compose_cfg(*store32_overrides(store.data_dir), "train.max_steps=7", "train.max_minutes=null")
    job = build(run_cfg, tmp_path / "run")
    messages = [r.getMessage() for r in caplog.records]
    (line,) = [m for m in messages if m.startswith("mcd.run: profile test32: ")]
    assert "; training: 7 steps of batch" in line and "training store " in line
    assert messages.index(line) < min(i for i, m in enumerate(messages) if m.startswith("store test32"))
    assert job.data_report["msamples"] == 0


def test_render_prints_a_progress_line_per_scene_and_frame(tmp_path, caplog):
    caplog.set_level(logging.INFO, logger="mcd.data.store")
    cfg = compose_cfg(*store32_overrides(tmp_path), "data.ref_spp=8", "data.ref_quality.target_db=null")
    StoreBuilder.from_cfg(cfg).ensure({"c1"}, progress=True)
    lines = [r.getMessage() for r in caplog.records if r.getMessage().startswith("render 1/1 scene cbox")]
    assert lines[0] == "render 1/1 scene cbox: 12 of its 12 frames here need rendering (ref,c1)"
    frames = lines[1:]
    assert len(frames) == 12 and all("elapsed 0:00:" in m and ", ETA 0:" in m for m in frames)
    assert frames[-1].startswith("render 1/1 scene cbox: frame 11 done (12/12)")
    assert frames[-1].endswith("ETA 0:00:00")
    assert not any("\r" in r.getMessage() for r in caplog.records)


@pytest.mark.parametrize("quality", [True, False])
def test_the_planned_renderer_calls_are_the_calls_a_render_makes(tmp_path, monkeypatch, quality):
    """The plan's time here is its samples at the pilot's marginal cost plus its renderer calls at the
    pilot's fixed cost per call (:func:`mcd.lit.workload.pilot_render`); the calls it counts are those a real
    render of the 32x32 Cornell box makes (with and without the reference quality target, whose test frames'
    references render in two halves)."""
    from mcd.data.renderer import SceneRenderer
    from mcd.lit.workload import counts, requested_buffers

    made = []
    for name in ("color", "gbuffer"):
        real = getattr(SceneRenderer, name)
        def counted(self, *a, _real=real, _name=name, **k):  # noqa: ANN001, ANN002, ANN003, ANN202
            made.append(_name)
            return _real(self, *a, **k)

        monkeypatch.setattr(SceneRenderer, name, counted)
    cfg = compose_cfg(*store32_overrides(tmp_path), *([] if quality else ["data.ref_quality.target_db=null"]))
    buffers = requested_buffers(cfg)
    StoreBuilder.from_cfg(cfg).ensure(sorted(buffers), progress=False)
    wk = counts(cfg, buffers, buffers)
    calls = wk["render_calls_per_scene"] * len(wk["scenes"])
    assert len(made) == calls, (len(made), calls)
    step = {"device": "cpu", "seconds": 1.0, "memory_mb": 1.0, "state_mb": 0.0}
    hours = derive(wk, made_pilot(wk, 2e-6, 0.1, "llvm_ad_rgb"), step, None)["render_hours_here"]
    assert hours == pytest.approx(tuple((s * 2e-6 + calls * 0.1) / 3600 for s in wk["samples"]))

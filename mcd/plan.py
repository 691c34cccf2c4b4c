"""``python -m mcd.plan data=<profile> capacity=<capacity> [+experiment=X]``: what a run will cost, printed
before anything is rendered or trained (docs/scale.md, "Plan").

The plan counts, from the config alone:

- the EXR store's bytes: per frame (the buffers ``mcd.render`` writes for this config: ``render.buffers``,
  default those the configured method reads plus ``ref`` and the uniform render at the budget,
  :func:`mcd.lit.workload.requested_buffers`; ``motion`` brings ``depth``), per scene and in all, uncompressed
  float32 (G-buffers and motion are stored ZIP-compressed, so smaller: an upper bound);
- the training store's bytes (:mod:`mcd.data.train_store`: the training and validation frames of
  ``data.train_scenes``, the run's buffers, float32 and float16), per frame as the pack writes it: square
  tiles, the last row and column padded (:func:`mcd.data.train_store.frame_bytes`), and in all;
- the samples to render: per frame, every colour buffer at its spp (references of test frames between
  ``data.ref_spp`` and ``data.ref_quality.max_spp``, the spp their quality target needs, plus the pilot of
  frame 0), the G-buffers once at ``data.gbuffer_spp``; times pixels, frames and scenes;
- steps per epoch (training clips of ``data.train_scenes`` over ``train.batch_size``,
  ``train.limit_train_batches``, shared by ``trainer.devices x trainer.num_nodes`` ranks) and the steps of the
  run (``train.epochs``, or ``train.max_steps``).

and it measures, on the machine it runs on, in this process (``plan.measure=false`` skips them):

- render speed: a pilot render of every real scene of the profile whose file is found (scenes differ by an
  order of magnitude), ``plan.pilot_frames`` frames at 1/``plan.pilot_scale`` of the size (at most 512x512
  pixels, :func:`mcd.lit.workload.pilot_size`) at ``plan.pilot_spp`` spp and 16 times that, after its load
  and one warm-up frame (:func:`mcd.lit.workload.pilot_render`): per scene, seconds per sample, per renderer
  call and per scene; the render time here is each scene's samples, calls and load at its own costs
  (:func:`mcd.lit.workload.render_seconds`), summed;
- training memory and time per step: one real optimiser step as the run trains it
  (:func:`mcd.lit.workload.train_step`): the training module's own step
  (:meth:`mcd.lit.module.DenoiseModule.training_step`: the clip's frames as the run computes them, those
  without gradient included) on ``train.batch_size`` synthetic clips
  (:func:`mcd.data.synthetic.synthetic_frame`) of ``data.clip_len`` frames, in ``trainer.precision`` (bf16
  autocast where it resolves to ``bf16-mixed``) and the weights' layout of ``train.channels_last``, backward
  and an Adam step: on a GPU at ``data.train_crop``, the peak of ``torch.cuda.max_memory_allocated``; on CPU
  CPU seconds and the rise of the peak resident memory (``VmHWM`` after ``/proc/self/clear_refs``) at the
  crop, or for a crop above ``plan.step_crop`` (a paper-sized step takes minutes on a small CPU) at that and
  half of it, extrapolated to the crop's pixels; plus 16 bytes per parameter (weights, gradients, Adam's two
  moments);
- the loader's clips/s per worker (:func:`mcd.data.loader_rate.measure`: the training store on a small
  synthetic store of the run's buffers at the crop size), against the rate a GPU needs (GPU steps/s x batch).

GPU figures: where CUDA is present the pilot runs on the CUDA variant and the step on the GPU, and the figures
are measured. Elsewhere they are derived: render time from the reference GPU's seconds per sample
(:data:`mcd.lit.workload.GPU_S_PER_SAMPLE`, measured by scripts/device_check.sh on the pilot scene:
docs/scale.md "Measured on a GPU"); a training step as the local step time divided by the local render time's
ratio to the reference GPU's (the same ratio assumed for both: a rough figure, said so in the output).
GPU-hours = render samples x GPU seconds per sample + run steps x GPU seconds per step.

``mcd.run`` and ``mcd.render`` log the counts alone before their work (:func:`mcd.lit.workload.announce`: the
figures of ``plan.measure=false`` for the buffers they render; no pilot render, no training step, no model):
the measured figures are this command's.
"""

from __future__ import annotations

import math
import tempfile
import time
from typing import Any

from omegaconf import DictConfig

from mcd.config.compose import hydra_main
from mcd.lit.workload import (
    GPU_S_PER_SAMPLE,
    _gb,
    _range,
    derive,
    pilot_render,
    summary,
    train_step,
    work,
)


def loader(cfg: DictConfig, buffers: list[str]) -> dict[str, Any]:
    """Clips/s of one loader worker on the training store at the run's crop and buffers
    (:func:`mcd.data.loader_rate.measure` on a small synthetic store in a temporary folder)."""
    from mcd.data.loader_rate import measure

    crop = min(int(cfg.data.train_crop), int(cfg.data.width), int(cfg.data.height))
    clip_len = int(cfg.data.clip_len)
    with tempfile.TemporaryDirectory(prefix="mcd-plan-") as tmp:
        return measure(tmp, buffers, width=max(crop, 2 * crop), height=crop, frames=clip_len + 1, crop=crop,
                       clip_len=clip_len, seconds=0.5)


# ----------------------------------------------------------------------------------------------------- plan


def plan(cfg: DictConfig, measure: bool = True) -> dict[str, Any]:
    """The counts of :func:`work`, and with `measure` the measured figures and the times and GPU-hours
    derived from them (module docstring)."""
    p: dict[str, Any] = {"work": work(cfg)}
    if not measure:
        return p
    wk = p["work"]
    pc = cfg.get("plan") or {}
    t0 = time.perf_counter()
    p["train_step"] = train_step(cfg, int(pc.get("step_crop", 96)))  # first: a clean peak-memory reading
    t1 = time.perf_counter()
    p["pilot"] = pilot_render(cfg, int(pc.get("pilot_scale", 8)), int(pc.get("pilot_spp", 8)),
                              int(pc.get("pilot_frames", 1)))
    t2 = time.perf_counter()
    p["loader"] = loader(cfg, wk["train_buffers"])
    p["measure_s"] = {"train_step": t1 - t0, "pilot": t2 - t1, "loader": time.perf_counter() - t2}
    p.update(derive(wk, p["pilot"], p["train_step"], p["loader"]))
    return p


def lines(p: dict[str, Any]) -> list[str]:
    """The plan as plain text lines, each figure with its arithmetic."""
    wk = p["work"]
    w, h, n, ns = wk["width"], wk["height"], wk["frames"], len(wk["scenes"])
    out = [
        f"plan for profile {wk['profile']}: {ns} scenes x {n} frames at {w}x{h}",
        f"EXR store ({','.join(wk['render_buffers'])}; float32, uncompressed upper bound): "
        f"{_gb(wk['exr_frame_bytes'])} per frame x {n} = {_gb(wk['exr_scene_bytes'])} per scene x {ns} = "
        f"{_gb(wk['exr_bytes'])}",
        f"training store ({','.join(wk['train_buffers'])}: {wk['train_channels']} channels, tiles padded): "
        f"{_gb(wk['train_store_frame_bytes']['float32'])} per frame x {wk['train_store_frames']} training "
        f"and validation frames = {_gb(wk['train_store_bytes']['float32'])} float32, "
        f"{_gb(wk['train_store_bytes']['float16'])} float16",
        f"samples: {_range(*wk['spp_per_scene'])} spp per pixel per scene (all buffers and frames) x {w * h} "
        f"pixels x {ns} scenes = {_range(*wk['samples'])}",
        f"training: {wk['train_clips']} clips / batch {wk['batch']} / {wk['ranks']} rank(s) = "
        f"{wk['steps_per_epoch']} steps per epoch; run: {wk['run_steps'] or '?'} steps "
        f"({wk['run_steps_how']})" if wk["train_error"] is None else
        f"training: none on this profile: {wk['train_error']}",
    ]
    if "pilot" not in p:
        return [*out, p.get("not_measured", "(not measured: plan.measure=false)")]
    pi, st = p["pilot"], p["train_step"]
    out += [
        f"pilot render: {len(pi['scenes'])} scene(s) at {pi['width']}x{pi['height']}, {pi['frames']} "
        f"frame(s) x {pi['spp']} and {pi['spp_hi']} spp on {pi['variant']}, each after its load and a "
        "warm-up frame: ns per sample (the difference of the two times over the difference of their "
        "samples), ms per renderer call (the rest of the smaller), s per scene (load and warm-up)"
        + ("" if not pi["skipped"] else f"; not loaded (their cost: the measured scenes' mean): "
           f"{'; '.join(pi['skipped'])}"),
        *(f"  {name}: {c['s_per_sample'] * 1e9:.1f} ns/sample, {c['s_per_call'] * 1e3:.0f} ms/call, "
          f"{c['s_per_scene']:.1f} s/scene"
          + ("" if pi["frames"] < 2 else f" (frames: {', '.join(f'{t:.2f}' for t in c['frame_seconds'])} s "
             f"at {pi['spp']} spp)") for name, c in pi["scenes"].items()),
        f"render time here: per scene, {_range(*wk['spp_per_scene'])} spp x {w * h} pixels x its ns/sample "
        f"+ {wk['render_calls_per_scene']} calls x its ms/call + its s/scene, over {ns} scenes = "
        f"{_range(*p['render_hours_here'], ' h')}",
        ("render on this GPU (measured): " if p["gpu_measured"] else
         f"render on the reference GPU (derived from its {_range(*(s * 1e9 for s in GPU_S_PER_SAMPLE))} ns "
         f"per sample on staircase2 at 1080p, docs/scale.md \"Measured on a GPU\"; this machine renders "
         f"{p['ratio']:.0f}x slower per sample; scenes differ): ")
        + f"{_range(*p['render_gpu_hours'], ' GPU-h')}",
        f"training step memory: {st['memory_mb']:.0f} MB for a step of {st['batch']} clip(s) of "
        f"{st['clip_len']} frames at {st['crop']}x{st['crop']} on {st['device']} ({st['precision']}, "
        f"{'channels-last' if st['observed']['channels_last'] else 'plain layout'}; {st['how']}; the "
        f"training module's step at {' and '.join(f'{c}x{c}' for c in st['measured_crops'])}"
        + ("" if st["measured_crops"] == [st["crop"]] else ", extrapolated to the crop's pixels")
        + ("" if st["measured_batch"] == st["batch"] else
           f", measured at {st['measured_batch']} clip(s) and scaled to the batch")
        + f") + {st['state_mb']:.0f} MB of weights, gradients and Adam's moments "
        f"({st['params']} parameters x 16 bytes) = {p['step_memory_mb']:.0f} MB per step",
        f"training step time: {st['seconds']:.3f} s per step of {st['batch']} clip(s) on {st['device']}"
        + ("" if st["device"] == "cuda" else
           f" / {p['ratio']:.0f} (this machine's render ratio to the reference GPU, assumed for training "
           "too: rough)")
        + f" = {p['gpu_step_s']:.3f} s per GPU step",
        f"loader: a GPU needs {wk['batch']} clips / {p['gpu_step_s']:.3f} s = {p['need_clips_per_s']:.1f} "
        f"clips/s; one worker reads {p['loader_clips_per_s']:.1f} clips/s warm, "
        f"{p['loader_cold_clips_per_s']:.1f} cold (training store, mcd.data.loader_rate): "
        f"{math.ceil(p['need_clips_per_s'] / max(p['loader_cold_clips_per_s'], 1e-9))} worker(s) at the "
        "cold rate",
    ]
    tr = p["train_gpu_hours"]
    out.append(f"training: {wk['run_steps'] or '?'} steps x {p['gpu_step_s']:.3f} s = "
               + ("? GPU-h (no step budget)" if tr is None else f"{tr:.3g} GPU-h"))
    out.append("total: " + summary(p))
    m = p["measure_s"]
    out.append(f"(measured here in {sum(m.values()):.0f} s: training step {m['train_step']:.0f} s, pilot "
               f"render {m['pilot']:.0f} s, loader {m['loader']:.0f} s; the machine's load stretches them)")
    return out


@hydra_main
def main(cfg: DictConfig) -> dict[str, Any]:
    from mcd.lit.transfer import prepare

    cfg, _ = prepare(cfg)
    measure = bool(cfg.get("plan", {}).get("measure", True))
    trained = bool(cfg.method.get("trainable", True))  # an untrained method has no training step to measure
    p = plan(cfg, measure=measure and trained)
    if measure and not trained:
        p["not_measured"] = (f"(not measured: method {cfg.method.name} is not trained "
                             "(method.trainable=false): no training step to measure; the counts only)")
    for line in lines(p):
        print(line, flush=True)
    return p


if __name__ == "__main__":
    main()

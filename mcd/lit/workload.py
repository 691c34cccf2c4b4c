"""What a run's work is, from its config, and what it costs where it runs: the counts and measurements
behind ``python -m mcd.plan`` (its docstring says what each figure is; docs/scale.md, "Plan"), and
:func:`announce`, the line of counts that ``mcd.run`` and ``mcd.render`` log before their work (no render, no
model: the plan alone measures). :func:`requested_buffers` is the buffer set ``render.buffers`` asks for
(``mcd.render``, ``mcd.pack``). It imports no loader measurement, so the commands can import it.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Iterable
from typing import Any

import numpy as np
from omegaconf import DictConfig, ListConfig

from mcd.core.machine import restart_peak_rss, status_mb
from mcd.data.buffers import BUFFERS, CHANNELS, COLOUR_BUFFERS, GBUFFERS, buffer_spp, run_buffers
from mcd.data.splits import clip_stride, split_of, test_frame_count
from mcd.data.store import StoreReader

log = logging.getLogger("mcd.lit.workload")

#: seconds per sample of this project's renderer on the reference GPU: the pilot scene of data=paper
#: (staircase2, the first of its scenes that the repository vendors) at 1920x1080, the range of the two pilots
#: of scripts/device_check.sh in reports/gpu_check (docs/scale.md "Measured on a GPU", with the command, the
#: commit and the machine); the plan's render time where no GPU is present
GPU_S_PER_SAMPLE = (29.2e-9, 30.3e-9)
HOUR = 3600.0


def requested_buffers(cfg: DictConfig) -> set[str]:
    """The buffer set ``render.buffers`` asks for: ``method`` (those the configured method reads, plus
    ``ref`` and the uniform render at the budget, as ``python -m mcd.run`` asks), ``all``, or a list
    (docs/data.md)."""
    spec = cfg.render.get("buffers", "method")
    if isinstance(spec, ListConfig | list | tuple):
        if not spec:
            raise ValueError("render.buffers=[]: an empty list asks for no buffer; give the buffers to "
                             "render (e.g. render.buffers=[ref,c4]), 'method' (those the configured method "
                             "reads) or 'all'")
        return set(spec) | {"ref"}
    if spec == "all":
        return set(BUFFERS)
    if spec == "method":
        from mcd.models import build

        return run_buffers(build(cfg).required_buffers(), cfg.budget)
    raise ValueError(
        f"render.buffers={spec!r}: expected 'method', 'all' or a list of buffers {list(BUFFERS)}"
    )


# ------------------------------------------------------------------------------------------------ arithmetic
def work(cfg: DictConfig) -> dict[str, Any]:
    """The plan's counts from the config alone (:mod:`mcd.plan`): :func:`counts` of the buffers
    ``render.buffers`` asks for and of those the configured method trains on (this builds the method)."""
    from mcd.models import build

    return counts(cfg, requested_buffers(cfg), run_buffers(build(cfg).required_buffers(), cfg.budget))


def counts(cfg: DictConfig, render_buffers: Iterable[str], train_buffers: Iterable[str]) -> dict[str, Any]:
    """Bytes, samples and steps of the config's profile when `render_buffers` are rendered (``motion``
    brings ``depth``) and `train_buffers` packed and trained on: arithmetic on counts, no render and no
    model. A training store frame counts as the pack writes it, its tiles padded
    (:func:`mcd.data.train_store.frame_bytes`)."""
    from mcd.data import train_store

    d = cfg.data
    reader = StoreReader.from_cfg(cfg, overrides=[])  # registers scenes given by path
    scenes, n = reader.scene_names, reader.n_frames
    w, h = int(d.width), int(d.height)
    asked = set(render_buffers)
    if "motion" in asked:
        asked.add("depth")
    render = [b for b in CHANNELS if b in asked]
    train = [b for b in CHANNELS if b in set(train_buffers)]
    frame_bytes = {b: w * h * CHANNELS[b] * 4 for b in render}
    n_test = test_frame_count(n, float(d.get("test_fraction", 0.2)))
    q = d.get("ref_quality")
    quality = q is not None and q.get("target_db") is not None
    ref_hi = int(q.get("max_spp", d.ref_spp)) if quality else int(d.ref_spp)
    lo = hi = 0  # samples per pixel of one scene
    for b in render:
        if b == "ref":
            lo += n * int(d.ref_spp) + (int(d.ref_spp) if quality else 0)
            hi += (n - n_test) * int(d.ref_spp) + n_test * ref_hi + (int(d.ref_spp) if quality else 0)
        elif b in COLOUR_BUFFERS:
            lo += n * buffer_spp(b, d)
            hi += n * buffer_spp(b, d)
    if any(b in GBUFFERS for b in render):
        lo += n * int(d.gbuffer_spp)
        hi += n * int(d.gbuffer_spp)
    # renderer calls of one scene (each has a fixed cost beside its samples, :func:`pilot_render`): one per
    # colour buffer and frame, the test frames' references in two halves (at most), one G-buffer pass per
    # frame, and the reference quality's pilot of two halves
    colour = [b for b in render if b in COLOUR_BUFFERS]
    calls = n * len(colour) + (n_test if "ref" in colour and quality else 0) + (2 if quality else 0)
    calls += n if any(b in GBUFFERS for b in render) else 0
    clip_stride(int(d.clip_len), d.get("train_clip_stride"))  # a bad key is an error, not "too short"
    try:  # a profile too short to train on still renders and tests (e.g. a transfer run's held-out scenes)
        split, train_error = split_of(n, d), None
    except ValueError as err:
        split, train_error = {"train": [], "val": []}, str(err)
    packed_frames = sum(len(c) for c in split["train"] + split["val"]) * len(d.train_scenes)
    channels = sum(CHANNELS[b] for b in train)
    packed = {dt: train_store.frame_bytes(h, w, channels, t) for dt, t in train_store.DTYPES.items()}
    clips = len(split["train"]) * len(d.train_scenes)
    t = cfg.train
    devices = cfg.trainer.get("devices", 1)
    ranks = (int(devices) if str(devices).isdigit() else 1) * int(cfg.trainer.get("num_nodes", 1) or 1)
    batch = int(t.batch_size)
    steps = math.ceil(clips / ranks / batch)
    limit = t.get("limit_train_batches", 1.0)
    steps = min(steps, int(limit)) if isinstance(limit, int) else math.ceil(steps * float(limit))
    if t.get("epochs") is not None:
        run_steps, how = int(t.epochs) * steps, f"train.epochs={int(t.epochs)} x {steps} steps"
    elif t.get("max_steps") is not None:
        run_steps, how = int(t.max_steps), f"train.max_steps={int(t.max_steps)}"
    else:
        run_steps, how = None, "no train.epochs or train.max_steps"
    return {
        "profile": reader.profile, "scenes": scenes, "frames": n, "width": w, "height": h,
        "render_buffers": render, "train_buffers": train,
        "exr_frame_bytes": sum(frame_bytes.values()), "exr_scene_bytes": sum(frame_bytes.values()) * n,
        "exr_bytes": sum(frame_bytes.values()) * n * len(scenes),
        "train_store_frames": packed_frames, "train_channels": channels,
        "train_store_frame_bytes": packed,
        "train_store_bytes": {dt: packed_frames * b for dt, b in packed.items()},
        "samples": (lo * w * h * len(scenes), hi * w * h * len(scenes)),
        "render_calls_per_scene": calls,
        "spp_per_scene": (lo, hi),
        "train_clips": clips, "batch": batch, "ranks": ranks, "steps_per_epoch": steps,
        "run_steps": run_steps, "run_steps_how": how, "train_error": train_error,
        "max_minutes": t.get("max_minutes"), "crop": int(d.train_crop), "clip_len": int(d.clip_len),
    }


# ---------------------------------------------------------------------------------------------- measurements
#: The most pixels of the pilot render: seconds per sample need no more, and a huge profile (or
#: ``plan.pilot_scale=1``) must not make the plan itself the long work.
PILOT_MAX_PIXELS = 512 * 512
#: The pilot's second spp, as a multiple of its first (:func:`pilot_render`).
PILOT_SPP_FACTOR = 16


#: The fewest pixels a side of the pilot render (the frame's own where it is smaller): a pilot of a few
#: pixels a side times the renderer's launch, not its samples, and puts a sample's cost several times too
#: low (docs/scale.md "Plan").
PILOT_MIN_SIDE = 64


def pilot_size(width: int, height: int, scale: int) -> tuple[int, int]:
    """The pilot's frame size: 1/`scale` of ``width x height``, at least :data:`PILOT_MIN_SIDE` pixels a side
    (at most the frame's), shrunk (keeping the aspect) to at most :data:`PILOT_MAX_PIXELS`."""
    w, h = (max(min(PILOT_MIN_SIDE, side), side // scale) for side in (width, height))
    shrink = math.sqrt(w * h / PILOT_MAX_PIXELS)
    if shrink > 1:
        w, h = max(8, int(w / shrink)), max(8, int(h / shrink))
    return w, h


def pilot_render(cfg: DictConfig, scale: int = 8, spp: int = 8, frames: int = 1) -> dict[str, Any]:
    """Seconds per sample, per renderer call and per scene here (:mod:`mcd.plan`), for every scene of the
    profile whose file is found: each at 1/`scale` of the size (at most :data:`PILOT_MAX_PIXELS`,
    :func:`pilot_size`), `frames` frames, each rendered at `spp` and at ``PILOT_SPP_FACTOR x spp`` after a
    warm-up frame.

    A call costs a fixed part (the kernel's launch, the film's development, whatever the samples) plus its
    samples; at a pilot's few thousand samples the fixed part is nearly all of the time, so one time over
    the samples overstates a small profile's render many-fold (docs/scale.md "Plan"). The two spp give
    both: ``s_per_sample`` is the difference of the two times over the difference of their samples,
    ``s_per_call`` what is left of the smaller call; ``s_per_scene`` is the scene's load and its warm-up
    frame (the JIT compiles each scene's kernels once). Scenes differ by an order of magnitude in each, so
    every scene is measured (``scenes``; those not found are listed in ``skipped``); ``scene`` is the first
    measured, the one the reference GPU's figure is compared with (:func:`derive`)."""
    from mcd.data.camera import interpolate_path
    from mcd.data.mitsuba_env import select_variant
    from mcd.data.renderer import SceneRenderer

    d = cfg.data
    variant = select_variant(str(cfg.render.get("variant", "auto")))
    reader = StoreReader.from_cfg(cfg, overrides=[])  # registers scenes given by path
    w, h = pilot_size(int(d.width), int(d.height), scale)
    spp_hi = PILOT_SPP_FACTOR * spp
    tried, scenes = [], {}
    for name in reader.scene_names:
        spec = reader.specs[name]
        try:
            spec.check_exists()
        except (FileNotFoundError, ValueError) as err:
            tried.append(f"{name} ({str(err).splitlines()[0][:80]})")
            continue
        t0 = time.perf_counter()
        loaded = spec.load(w, h, None if d.get("max_depth") is None else int(d.max_depth), int(d.segments))
        cams = interpolate_path(loaded.nodes, int(d.frames_per_segment))
        r = SceneRenderer(loaded.scene, w, h, loaded.fov)
        r.set_camera(np.asarray(cams[0], dtype=np.float64))
        r.color(spp, 0)  # warm-up: the JIT compiles the kernels
        setup = time.perf_counter() - t0
        low, high = [], []
        for k in range(frames):
            r.set_camera(np.asarray(cams[(k + 1) * len(cams) // (frames + 1)], dtype=np.float64))
            for n_spp, times in ((spp, low), (spp_hi, high)):
                t0 = time.perf_counter()
                r.color(n_spp, k + 1)
                times.append(time.perf_counter() - t0)
        per_sample = (sum(high) - sum(low)) / (w * h * (spp_hi - spp) * frames)
        if per_sample <= 0:  # the machine's noise above the samples' cost: all of it counted per sample
            per_sample = sum(high) / (w * h * spp_hi * frames)
        per_call = max(0.0, sum(low) / frames - per_sample * w * h * spp)
        scenes[name] = {"s_per_sample": per_sample, "s_per_call": per_call, "s_per_scene": setup,
                        "frame_seconds": low, "frame_seconds_hi": high}
    if not scenes:
        raise FileNotFoundError(f"plan: no scene of profile {reader.profile} could be loaded for the pilot "
                                f"render: {'; '.join(tried)}. Set paths.scenes_dir (docs/scenes.md), or "
                                "plan.measure=false")
    return {"scene": next(iter(scenes)), "variant": variant, "width": w, "height": h, "spp": spp,
            "spp_hi": spp_hi, "frames": frames, "scenes": scenes, "skipped": tried}


def render_seconds(wk: dict, pilot: dict) -> tuple[float, float]:
    """The profile's render here, seconds (fewest and most samples, :func:`counts`): per scene its samples
    at the scene's cost per sample, its renderer calls at its cost per call and its load and compile once
    (:func:`pilot_render`); a scene the pilot could not load costs the measured scenes' mean."""
    measured = pilot["scenes"]
    mean = {k: float(np.mean([m[k] for m in measured.values()]))
            for k in ("s_per_sample", "s_per_call", "s_per_scene")}
    calls = wk["render_calls_per_scene"]
    total = [0.0, 0.0]
    for name in wk["scenes"]:
        c = measured.get(name, mean)
        for i, spp in enumerate(wk["spp_per_scene"]):
            total[i] += spp * wk["width"] * wk["height"] * c["s_per_sample"] + calls * c["s_per_call"] \
                + c["s_per_scene"]
    return total[0], total[1]


def train_step(cfg: DictConfig, step_crop: int = 96, batch: int | None = None) -> dict[str, Any]:
    """One optimiser step of the configured method as its run trains it (:mod:`mcd.plan`, the sweep's plan
    :mod:`mcd.lit.sweep_plan`): seconds and activation memory in MB of one step of ``train.batch_size`` clips
    of ``data.clip_len`` frames at ``data.train_crop``, and what was measured (docs/scale.md "Plan").

    The step is the training's own: :meth:`mcd.lit.module.DenoiseModule.on_fit_start` (the weights
    channels-last where ``train.channels_last``), :meth:`~mcd.lit.module.DenoiseModule.training_step` (the
    clip's frames as :meth:`~mcd.lit.module.DenoiseModule.clip_plan` runs them: those before the last
    ``train.grad_frames`` without gradient, through the model's ``advance`` where it has one; the configured
    loss) under ``trainer.precision`` as :mod:`mcd.lit.precision` resolves it on this device (bf16 autocast
    for ``bf16-mixed``), backward, the gradients' norm
    (:meth:`~mcd.lit.module.DenoiseModule.on_before_optimizer_step`) and an Adam step, on synthetic clips
    (:func:`mcd.data.synthetic.synthetic_frame`). Not in it: the data loader, validation and Lightning's loop.

    `batch`: the clips per measured step, ``train.batch_size`` by default; a smaller one is scaled linearly to
    ``train.batch_size`` (its fixed cost per step counted once per clip: an overestimate).

    On a GPU: at the crop, after a warm-up step (cuDNN's algorithm choice, the allocator's first blocks),
    the median wall time of three steps and the peak of ``torch.cuda.max_memory_allocated``; at one clip
    scaled to the batch where the batch does not fit. On CPU: on one thread, the median of three steps after
    a warm-up step at the size (one step alone moved by up to 1.6x between two plans on a loaded machine), as
    CPU seconds over torch's threads (the step on an idle machine, ideal scaling; a shared machine stretches
    wall time, not this) and the rise of the peak resident memory; at the crop where it is at most
    `step_crop`, else at `step_crop` / 2 and `step_crop` and extrapolated to the crop's pixels along the line
    through the two (a fixed part plus a part per pixel), or scaled by the pixel ratio where the two are out
    of order (noise). The whole batch at the crop is the plan's step: extrapolated from a third and two
    thirds of the crop's side, the same step came out 1.2-1.4x over, one clip times the batch 2.3-3.4x over
    (``tools/plan_step_check.py``; notes/scaling_plan.md "The plan re-measured with the configured step").

    ``observed``: what the model saw in the last timed step, read by a hook on its ``forward`` (the frames it
    computed an output for): per call the batch and frame size, whether autocast was on and to which dtype,
    whether gradient was enabled; and whether its 4-D weights were channels-last.
    """
    import warnings

    import torch

    from mcd.data.synthetic import synthetic_frame
    from mcd.lit.module import DenoiseModule
    from mcd.lit.precision import autocast_to
    from mcd.lit.precision import resolve as resolve_precision
    from mcd.losses import build_loss
    from mcd.models import build

    device = "cuda" if torch.cuda.is_available() else "cpu"
    module = DenoiseModule(cfg, build(cfg).train(), build_loss(cfg)).to(device)
    model = module.model
    module.on_fit_start()  # the loss to the device; channels-last weights (and compile) as the run's fit
    names = run_buffers(model.required_buffers(), cfg.budget)
    crop = min(int(cfg.data.train_crop), int(cfg.data.width), int(cfg.data.height))
    clip_len, full = int(cfg.data.clip_len), int(cfg.train.batch_size)
    clips = full if batch is None else min(int(batch), full)
    precision = resolve_precision(str(cfg.trainer.get("precision", "auto")),
                                  "cpu" if device == "cpu" else "gpu")
    half = {"bf16-mixed": torch.bfloat16, "bf16": torch.bfloat16,
            "16-mixed": torch.float16, "16": torch.float16}.get(precision)
    # the rate does not change a step's cost, and a rate the job refuses (train.lr=-1) is the job's to
    # record in its error.json, not the plan's to end the sweep on; weight decay's term is timed when on
    opt = torch.optim.Adam(model.parameters(), lr=1e-3,
                           weight_decay=1e-4 if float(cfg.train.weight_decay) != 0 else 0.0)
    seen: list[dict[str, Any]] = []

    def look(_: torch.nn.Module, args: tuple) -> None:
        x = next(v for v in args[0].values() if isinstance(v, torch.Tensor))
        seen.append({"batch": int(x.shape[0]), "size": [int(s) for s in x.shape[-2:]],
                     "autocast": str(torch.get_autocast_dtype(device)).removeprefix("torch.")
                     if torch.is_autocast_enabled(device) else None, "grad": torch.is_grad_enabled()})

    def step(size: int, n: int) -> tuple[float, float]:
        """(seconds, MB) of one optimiser step of `n` clips at `size`."""
        clip = synthetic_frame(names, size, size, lead=(n, clip_len), device=device)
        seen.clear()
        if device == "cuda":
            torch.cuda.synchronize()
            torch.cuda.reset_peak_memory_stats()
            base = torch.cuda.memory_allocated()
        else:
            restart_peak_rss()  # VmHWM := VmRSS
            base = status_mb("VmRSS")
        t0, c0 = time.perf_counter(), time.process_time()
        with warnings.catch_warnings():  # self.log without a Trainer: warned and skipped
            warnings.filterwarnings("ignore", message=".*self.log.*")
            with autocast_to(torch.device(device), half):
                loss = module.training_step(clip, 0)
            loss.backward()
            module.on_before_optimizer_step(opt)
        opt.step()
        opt.zero_grad(set_to_none=True)
        if device == "cuda":
            torch.cuda.synchronize()
            return time.perf_counter() - t0, (torch.cuda.max_memory_allocated() - base) / 2**20
        return (time.process_time() - c0) / threads, status_mb("VmHWM") - base

    threads = torch.get_num_threads()
    hook = model.register_forward_pre_hook(look)
    try:
        if device == "cuda":
            try:
                step(crop, clips)  # warm-up at the crop: cuDNN's algorithms, the allocator's blocks
                runs = [step(crop, clips) for _ in range(3)]
            except torch.cuda.OutOfMemoryError:
                torch.cuda.empty_cache()
                clips = 1
                step(crop, clips)
                runs = [step(crop, clips) for _ in range(3)]
            seconds, memory = float(np.median([r[0] for r in runs])), max(r[1] for r in runs)
            sizes = [crop]
            how = "median wall time of 3 steps after a warm-up; torch.cuda.max_memory_allocated"
        else:
            torch.set_num_threads(1)  # CPU time without the threads' spin-waiting; restored below
            sizes = [crop] if crop <= step_crop else [max(8, step_crop // 2), step_crop]
            measured = []
            for c in sizes:
                step(c, clips)  # warm-up at the size: oneDNN's primitives for its shapes, Adam's state
                runs = [step(c, clips) for _ in range(3)]
                measured.append((float(np.median([r[0] for r in runs])), max(r[1] for r in runs)))
            (s1, m1), (s2, m2) = measured if len(measured) == 2 else measured * 2
            p1, p2, p = sizes[0] ** 2, sizes[-1] ** 2, crop ** 2
            if p2 == p:
                seconds, memory = s2, m2
            elif p2 > p1 and s2 > s1 and m2 > m1:
                seconds, memory = s2 + (s2 - s1) / (p2 - p1) * (p - p2), m2 + (m2 - m1) / (p2 - p1) * (p - p2)
            else:
                seconds, memory = s2 * p / p2, m2 * p / p2
            how = (f"CPU seconds of one thread / {threads} threads, median of 3 steps after a warm-up; rise "
                   "of peak RSS (VmHWM)")
    finally:
        hook.remove()
        if device == "cpu":
            torch.set_num_threads(threads)
    layout = [w.is_contiguous(memory_format=torch.channels_last) for w in model.parameters() if w.dim() == 4]
    params = sum(w.numel() for w in model.parameters())
    return {"device": device, "seconds": seconds * full / clips, "memory_mb": memory * full / clips,
            "how": how, "crop": crop, "measured_crops": sizes, "batch": full, "measured_batch": clips,
            "clip_len": clip_len, "precision": precision,
            "observed": {"calls": list(seen), "channels_last": bool(layout) and all(layout)},
            "params": params, "state_mb": params * 16 / 2**20}


def derive(wk: dict, pilot: dict, step: dict, loader_rate: dict | None) -> dict[str, Any]:
    """Times, GPU-hours and the loader's need from the counts and the measurements (:mod:`mcd.plan`)."""
    here = pilot["scenes"][pilot["scene"]]["s_per_sample"]  # the first scene's (the GPU's is staircase2's)
    gpu_measured = pilot["variant"].startswith("cuda")
    gpu_sps = (here, here) if gpu_measured else GPU_S_PER_SAMPLE
    ratio = here / float(np.mean(GPU_S_PER_SAMPLE))  # times faster the reference GPU renders (per sample)
    cpu_step = step["seconds"]  # one optimiser step of the batch
    gpu_step = cpu_step if step["device"] == "cuda" else cpu_step / ratio
    steps = wk["run_steps"]
    out = {
        "render_hours_here": tuple(t / HOUR for t in render_seconds(wk, pilot)),
        "render_gpu_hours": (wk["samples"][0] * gpu_sps[0] / HOUR, wk["samples"][1] * gpu_sps[1] / HOUR),
        "gpu_measured": gpu_measured, "ratio": ratio, "gpu_step_s": gpu_step,
        "step_memory_mb": step["memory_mb"] + step["state_mb"],
        "train_gpu_hours": None if steps is None else steps * gpu_step / HOUR,
        "need_clips_per_s": wk["batch"] / gpu_step,
    }
    if loader_rate is not None:
        out["loader_clips_per_s"] = loader_rate["clips_per_s"]
        out["loader_cold_clips_per_s"] = loader_rate["cold_clips_per_s"]
    return out


def _gb(n: float) -> str:
    return f"{n / 1e12:.2f} TB" if n >= 1e12 else f"{n / 1e9:.2f} GB" if n >= 1e9 else f"{n / 1e6:.1f} MB"


def _range(a: float, b: float, unit: str = "") -> str:
    return f"{a:.3g}{unit}" if math.isclose(a, b, rel_tol=1e-3) else f"{a:.3g}-{b:.3g}{unit}"


def summary(p: dict[str, Any]) -> str:
    """The plan in one line."""
    wk = p["work"]
    s = (f"plan {wk['profile']}: EXR store {_gb(wk['exr_bytes'])}, training store "
         f"{_gb(wk['train_store_bytes']['float32'])} (float32); {_range(*wk['samples'])} samples")
    if "render_hours_here" in p:
        s += f" = {_range(*p['render_hours_here'], ' h')} here"
    if "render_gpu_hours" in p:
        tr = p["train_gpu_hours"]
        total = [r + (tr or 0.0) for r in p["render_gpu_hours"]]
        s += (f"; GPU-hours: render {_range(*p['render_gpu_hours'])} + training "
              f"{'?' if tr is None else f'{tr:.3g}'} = {_range(*total)}"
              + ("" if p["gpu_measured"] else " (derived from the reference GPU)"))
    return s


def announce(cfg: DictConfig, what: str, buffers: Iterable[str], train: bool, share: float = 1.0) -> str:
    """Log, and return, the line `what` (``mcd.run``, ``mcd.render``) prints before its work: the plan's
    counts (:func:`counts`, the figures ``python -m mcd.plan plan.measure=false`` prints for the same config)
    for the `buffers` the command renders and, where `train`, trains on. No render, no model: the times
    need a pilot render and a training step, which ``python -m mcd.plan`` measures.

    `share`: the part of the profile's render units this process renders (a shard's units over all)."""
    wk = counts(cfg, buffers, buffers)
    line = (f"{what}: profile {wk['profile']}: {len(wk['scenes'])} scenes x {wk['frames']} frames at "
            f"{wk['width']}x{wk['height']}; EXR store {_gb(wk['exr_bytes'])} "
            f"({','.join(wk['render_buffers'])}); {_range(*wk['samples'])} samples to render")
    if share < 1.0:
        line += f", {share:.3g} of them in this process"
    if train:
        line += (f"; training store {_gb(wk['train_store_bytes']['float32'])} (float32); training: "
                 + (f"{wk['run_steps'] or '?'} steps of batch {wk['batch']} ({wk['run_steps_how']})"
                    if wk["train_error"] is None else f"none on this profile: {wk['train_error']}"))
        if wk["max_minutes"] is not None:
            line += f", at most {wk['max_minutes']} minutes (train.max_minutes)"
    line += "; render and step times: python -m mcd.plan measures them"
    log.info("%s", line)
    return line

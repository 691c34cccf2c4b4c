"""Input (b) of ``mcd.denoise``: a Mitsuba scene, rendered and sampled for real (docs/denoise.md, "Scenes: the
real loop"; docs/method.md "Adaptive sampling"; paper Sec. 3.1).

Per frame (the scene's own camera; with ``frames > 1`` a path derived from it as for the benchmark's scenes,
:func:`mcd.data.scenes.derive_nodes`): render ``c_1`` (1 spp, ``N`` samples) and the G-buffers (their own
samples, not part of the colour budget, as in the benchmark), run the sampling network ``F_s``, normalise its
map to exactly ``N * (s - 1)`` samples, render those per-pixel counts with Mitsuba
(:func:`mcd.data.spp_map_render.render_spp_map`, injected through :func:`mcd.sampling.real_renderer`), then
the second stage. Colour samples per frame: ``N + N * (s - 1) = N * s`` exactly (checked). A uniform method
renders ``c_s`` (``N * s``) instead. NTASAD's first frame also reads ``c_s`` (its stand-in for a previous
output), rendered on top and reported as ``extra_samples``; no other adaptive method renders ``c_s`` for
itself. The film size defaults to the scene's own (:func:`film_size`).

With ``reference_spp``, every method is scored on the same terms (docs/denoise.md, "Scores of the real loop"):
one exposure for the scores (given, or from the first lit frame's reference; the network's own comes from its
input, as without a reference), the same uniform input ``c_s`` beside an adaptive method's own input, a
reference raised to a target quality with its own noise estimated (:mod:`mcd.denoise.reference`) and written
beside the outputs; for adaptive methods also the stack ``c_1 .. c_{2^levels}`` of the simulated render, run
through a copy of the model (what the benchmark measures) and compared with the real loop. Renders made only
for the scores are counted as ``score_samples``.
"""

from __future__ import annotations

import copy
import logging
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from mcd.config.methods import display_name
from mcd.core.metrics import psnr, ssim
from mcd.data.buffers import GBUFFERS, uniform_buffer
from mcd.data.camera import Camera, backward_motion, interpolate_path
from mcd.data.exposure import depth_scale, input_exposure, normalise
from mcd.data.renderer import derive_seed
from mcd.data.scenes import SceneNotFoundError, SceneSpec, path_scene_name
from mcd.denoise.output import frame_files, hwc, write_frame
from mcd.denoise.precision import layout, prepare, running
from mcd.denoise.reference import MAX_SPP, TARGET_DB, ReferencePlan
from mcd.denoise.weights import Loaded
from mcd.sampling import real_renderer, stack_names

log = logging.getLogger(__name__)


class SceneLoadError(RuntimeError):
    """A scene file that Mitsuba cannot load; the message names it and what to do."""


def load_scene(path: Path, width: int, height: int, max_depth: int | None, frames: int,
               camera_path: dict[str, Any] | None = None) -> tuple[Any, list]:
    """``(loaded scene, camera transforms)``: the scene's own camera, or a path of ``frames`` derived from it
    (``camera_path``: ``dolly``, ``truck``, ``pan_deg`` or ``nodes`` as in docs/scenes.md, "Camera paths")."""
    spec = SceneSpec(path_scene_name(path), "xml", file=path.resolve(), path=dict(camera_path or {}),
                     missing_hint="check the path given to --scene")
    try:
        loaded = spec.load(width, height, max_depth, segments=1)
    except SceneNotFoundError:
        raise
    except Exception as exc:  # Mitsuba raises RuntimeError / ValueError with its parser's message
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise SceneLoadError(
            f"{path}: the scene did not load in Mitsuba 3 ({first}). A Mitsuba 0.5/0.6 scene must be "
            "converted to the version 3 format first, and every file it references must sit where it says "
            "(docs/scenes.md, 'Your own scene')") from exc
    cams = [loaded.nodes[0]] if frames == 1 else interpolate_path(loaded.nodes, frames)
    return loaded, cams


def _tensor(img: np.ndarray, device: torch.device) -> torch.Tensor:
    return torch.from_numpy(np.ascontiguousarray(img.transpose(2, 0, 1)))[None].to(device)


class AdaptiveRender:
    """``render_sum`` for :func:`mcd.sampling.real_renderer`: renders a map's counts with Mitsuba, counting
    the samples it spends; the sum comes back in the network's exposure, sanitised like the training data."""

    def __init__(self, scene: Any, sensor: Any, seed: int, exposure: float):
        self.scene, self.sensor, self.seed, self.exposure = scene, sensor, seed, exposure
        self.samples = 0

    def __call__(self, m: torch.Tensor) -> torch.Tensor:
        from mcd.data.spp_map_render import render_spp_map

        counts = m[0, 0].round().long().cpu().numpy()
        img = render_spp_map(self.scene, counts, self.seed, sensor=self.sensor)
        self.samples += int(counts.sum())
        img = normalise(img, "adaptive", self.exposure, 1.0, colour=True)[0]
        return _tensor(img * counts[..., None].astype(np.float32), m.device)


def film_size(scene: Any) -> tuple[int, int]:
    """``(width, height)`` of the film a loaded Mitsuba scene declares (its first sensor's)."""
    w, h = scene.sensors()[0].film().crop_size()
    return int(w), int(h)


def denoise_scene(loaded_model: Loaded, path: Path, out_dir: Path, device: torch.device,
                  width: int | None = None, height: int | None = None, frames: int = 1,
                  gbuffer_spp: int = 16, seed: int = 0, reference_spp: int = 0, progress: bool = True,
                  dtype: torch.dtype | None = None,
                  exposure: float | None = None, reference_db: float | None = TARGET_DB,
                  reference_max_spp: int = MAX_SPP,
                  check_work: Callable[[int, int], None] | None = None) -> dict[str, Any]:
    """Render and denoise ``path`` (module docstring) with autocast to ``dtype`` (None: fp32;
    mcd/denoise/precision.py); returns a summary with per-frame samples and, with ``reference_spp``, scores.

    ``width`` / ``height`` None: the scene's own film size. ``exposure`` None: the network's from the own
    input of the first frame that is not black (a robust mean brought to ``data.exposure_target``,
    :func:`mcd.data.exposure.input_exposure`; the black frames before it see the same input at any exposure),
    with or without a reference, so that scoring never changes the outputs; the scores' from the first lit
    frame's reference (the same for every method; :class:`mcd.denoise.reference.ReferencePlan`).
    ``reference_db`` None: every reference at ``reference_spp``. ``check_work(width, height)``: called once
    the film size is known, before anything is rendered (mcd-denoise's work limit, mcd/denoise/work.py).
    """
    from mcd.data.mitsuba_env import select_variant
    from mcd.data.renderer import SceneRenderer

    plan = ReferencePlan(reference_spp, reference_db, reference_max_spp, seed) if reference_spp else None
    if exposure is not None and not (np.isfinite(exposure) and exposure > 0):
        raise ValueError(f"--exposure={exposure}: give a positive number, or leave it out (automatic)")
    select_variant("auto")
    cfg = loaded_model.cfg
    model = prepare(loaded_model.model.to(device), dtype)
    budget = int(cfg.budget)
    levels = int((cfg.method.get("sampling", None) or {}).get("levels", 5))
    reads = set(model.required_buffers())
    adaptive = loaded_model.adaptive
    # the one buffer an adaptive method reads beyond its budget: NTASAD's first-frame stand-in c_s
    first_frame_extra = getattr(model, "first_key", None) if adaptive else None
    scene, cams = load_scene(path, width, height, cfg.data.get("max_depth"), frames)
    if width is None or height is None:
        film_w, film_h = film_size(scene.scene)
        width, height = width or film_w, height or film_h
    if check_work is not None:
        check_work(width, height)
    r = SceneRenderer(scene.scene, width, height, scene.fov)
    n = width * height
    target = float(cfg.data.get("exposure_target", 0.5))
    sim_model = copy.deepcopy(model) if plan is not None and adaptive else None
    exposure_source = "--exposure" if exposure is not None else None
    score_exposure, score_source = exposure, exposure_source  # the scores' exposure (one for every method)
    scale, scale_from = 1.0, None  # the depth scale, and the frame it came from (the first with a hit)
    rows: list[dict[str, Any]] = []
    model.reset()
    if sim_model is not None:
        sim_model.reset()
    t0 = time.perf_counter()
    files: list[str] = []  # what this run writes: the record's outputs (not an earlier run's beside them)
    prev_cam: Camera | None = None
    uniform = uniform_buffer(budget)

    for f, to_world in enumerate(tqdm(cams, desc=f"denoise {path.name}", unit="frame", disable=not progress)):
        r.set_camera(to_world)
        cam = r.camera(to_world)
        spent = {"c1": 0, "adaptive": 0, "uniform": 0, "extra": 0, "scores": 0}
        ref = None
        if plan is not None:
            before = r.samples_rendered
            if not plan.settled:  # frame 0, or the first lit frame after black ones
                ref, score_exposure = plan.first(r, score_exposure, target, f)
                if score_source is None and score_exposure is not None:
                    score_source = f"frame {f}'s reference"
            else:
                ref = plan.render(r, f, score_exposure)
            spent["scores"] += r.samples_rendered - before
        raw: dict[str, np.ndarray] = {}
        if adaptive:
            raw["c1_in"] = r.color(1, derive_seed(seed, "c1_in", f))
            spent["c1"] = n
        read_uniform = (uniform in reads) if not adaptive else (f == 0 and first_frame_extra == uniform)
        if read_uniform or plan is not None:  # the method's input, or the uniform input of the scores
            raw[uniform] = r.color(budget, derive_seed(seed, uniform, f))
            key = "extra" if adaptive and read_uniform else "uniform" if read_uniform else "scores"
            spent[key] += n * budget
        gb = r.gbuffer(gbuffer_spp, derive_seed(seed, "gbuffer", f))
        if exposure is None:  # what the user has: the method's own input, never the reference
            # the first frame whose input is not black, as for frames (mcd.denoise.frames.FrameSequence): a
            # black frame 0 gave 1, and the lit frames after it reached the network far too dark; the frames
            # before are black, so their input is the same at any exposure
            exposure = input_exposure(raw.get("c1_in", raw.get(uniform)), target,
                                      f"{path}: frame {f}'s input")
            if exposure is not None:
                exposure_source = f"frame {f}'s input"
                if f:
                    log.info("%s: the input of frames 0-%d is black; network exposure x%.4g from frame %d",
                             path, f - 1, exposure, f)
        net = 1.0 if exposure is None else exposure  # the network's exposure of this frame
        depth = gb["depth"]
        if scale_from is None and np.any(np.isfinite(depth) & (depth > 0)):
            # the first frame with a hit, as for frames (mcd.denoise.frames.FrameSequence._depth_scale): a
            # frame 0 that hits nothing (the sky) gave 1, and a scene in centimetres reached the network far
            # off; the frames before hit nothing, so their depth (0) is the same at any scale
            scale, scale_from = depth_scale(depth), f
            if f:
                log.info("%s: frames 0-%d hit nothing (depth 0); depth scale %.4g from frame %d", path, f - 1,
                         scale, f)
        x: dict[str, torch.Tensor | None] = {}
        for name, img in {**raw, **{b: gb[b] for b in GBUFFERS if b in reads}}.items():
            x[name] = layout(_tensor(normalise(img, name, net, scale, colour=name not in GBUFFERS)[0],
                                     device), dtype)
        uniform_input = raw.get(uniform) if ref is not None else None
        if not read_uniform:
            x.pop(uniform, None)  # rendered for the scores only: the method never sees it
        if "motion" in reads:
            mv = (np.zeros((height, width, 2), np.float32) if prev_cam is None
                  else backward_motion(gb["depth"], cam, prev_cam))
            x["motion"] = layout(_tensor(mv, device), dtype)
        prev_cam = cam
        row: dict[str, Any] = {"frame": f}
        with running(device, dtype):
            if adaptive:
                placeholders = {k: torch.zeros_like(x["c1_in"]) for k in stack_names(levels)}
                render = AdaptiveRender(scene.scene, r.sensor, derive_seed(seed, "adaptive", f), net)
                with real_renderer(render):
                    out = model({**placeholders, **x})
                spent["adaptive"] = render.samples
            else:
                out = model(x)
        colour_spent = spent["c1"] + spent["adaptive"] + spent["uniform"]
        if colour_spent != n * budget:
            raise RuntimeError(f"frame {f}: {colour_spent} colour samples spent, not N*s = {n * budget}")
        row.update(samples=colour_spent, budget_samples=n * budget, extra_samples=spent["extra"],
                   gbuffer_samples=n * gbuffer_spp)
        written = dict(out)
        if ref is not None:
            assert uniform_input is not None
            scored = 1.0 if score_exposure is None else score_exposure  # None: black so far, any exposure
            to_scores = float(scored / net)  # the network's exposure -> the scores'
            ref_img = normalise(ref.image, "ref", scored, scale, colour=True)[0]
            written["reference"] = _tensor(normalise(ref.image, "ref", net, scale, colour=True)[0],
                                           device)
            row.update(reference_spp=ref.spp, reference_psnr_estimate=ref.psnr_estimate)
            scored_uniform = _tensor(normalise(uniform_input, uniform, scored, scale, colour=True)[0],
                                     device)
            adaptive_input = out.get("adaptive")
            row.update(scores(ref_img, scored_uniform,
                              None if adaptive_input is None else adaptive_input.float() * to_scores,
                              out["output"].float() * to_scores))
            if sim_model is not None:
                before = r.samples_rendered
                stack = {k: layout(_tensor(normalise(r.color(2 ** j, derive_seed(seed, k, f)), k, net,
                                                     scale, colour=True)[0], device), dtype)
                         for j, k in enumerate(stack_names(levels))}
                spent["scores"] += r.samples_rendered - before
                with running(device, dtype):
                    sim = sim_model({**x, **stack})
                row["psnr_simulated"] = psnr(hwc(sim["output"].float() * to_scores), ref_img)
                row["psnr_output_minus_simulated"] = row["psnr_output"] - row["psnr_simulated"]
        row["score_samples"] = spent["scores"]
        stem = f"{scene.spec.name}_{f:04d}"
        exrs = write_frame(out_dir, stem, written, net)
        files += [n for exr in exrs for n in (exr.name, f"{exr.stem}.png")]
        stale = [n for n in frame_files(stem) if n not in files and (out_dir / n).is_file()]
        if stale:
            log.warning("%s: %s: from an earlier run into this folder, not written by this one (nor listed "
                        "in its record); delete them, or denoise into an empty -o", out_dir, ", ".join(stale))
        rows.append(row)
    if exposure is None:
        log.warning("%s: the input of every frame is black: network exposure x1; give --exposure if the "
                    "scene is lit", path)
    return {"frames": rows, "size": [height, width], "budget": budget, "exposure": exposure or 1.0,
            "exposure_source": exposure_source or "none: every frame's input is black",
            "score_exposure": (score_exposure or 1.0) if plan else None,
            "score_exposure_source": (score_source or "none: every frame's reference is black") if plan
            else None, "mean": mean_scores(rows),
            "reference": plan.summary() if plan is not None else None,
            "seconds": time.perf_counter() - t0, "out_dir": str(out_dir), "variant": _variant(),
            "scene": str(path), "outputs": files}


#: The score columns: the same uniform render ``c_s`` for every method, an adaptive method's own input, the
#: output.
COLUMNS = (("uniform", "uniform input"), ("adaptive", "adaptive input"), ("output", "output"))


def scores(ref: np.ndarray, uniform: torch.Tensor | None, adaptive: torch.Tensor | None,
           output: torch.Tensor) -> dict[str, float]:
    """PSNR and SSIM (mcd/core/metrics.py) of each column present against ``ref``, all in one exposure."""
    row = {}
    for key, img in (("uniform", uniform), ("adaptive", adaptive), ("output", output)):
        if img is not None:
            x = hwc(img)
            row[f"psnr_{key}"], row[f"ssim_{key}"] = psnr(x, ref), ssim(x, ref)
    return row


def mean_scores(rows: list[dict[str, Any]]) -> dict[str, float]:
    """The mean over the frames of every score and of the reference's estimate."""
    keys = [k for k in rows[0] if k.startswith(("psnr_", "ssim_", "reference_psnr"))] if rows else []
    return {k: float(np.mean([row[k] for row in rows])) for k in keys}


def report_lines(report: dict[str, Any]) -> list[str]:
    """What ``mcd-denoise --scene`` prints: per frame its samples (budget, extra, for the scores) and scores,
    then the means, the reference and the exposure (docs/denoise.md, "Scores of the real loop")."""
    lines = []
    for row in report["frames"]:
        line = f"frame {row['frame']}: {row['samples']} colour samples = N*s"
        if row["extra_samples"]:
            line += (f" + {row['extra_samples']} read beyond the budget ({display_name('ntasad')}'s "
                     "first-frame stand-in c_s)")
        if row.get("score_samples"):
            line += f"; {row['score_samples']} more for the scores only"
        lines.append(line + _score_text(row))
    ref = report.get("reference")
    if ref and report["frames"]:
        lines.append(f"mean of {len(report['frames'])} frame(s): " + _score_text(report["mean"]).lstrip("; "))
        lines.append(f"reference: {ref['spp']} spp, its own noise estimated at PSNR "
                     f"{report['mean']['reference_psnr_estimate']:.2f} dB (pilot {ref['pilot_spp']} spp: "
                     f"{ref['pilot_db']:.2f} dB; target {ref['target_db']} dB, cap {ref['max_spp']} spp); "
                     "a score near it is limited by the reference")
    line = f"network exposure {report['exposure']:.6g} (from {report['exposure_source']})"
    if report.get("score_exposure") is not None:
        line += (f"; scores in exposure {report['score_exposure']:.6g} (from "
                 f"{report['score_exposure_source']}), the same for every column")
    lines.append(line)
    return lines


def _score_text(row: dict[str, Any]) -> str:
    parts = [f"{label} {row[f'psnr_{key}']:.2f} dB / SSIM {row[f'ssim_{key}']:.4f}"
             for key, label in COLUMNS if f"psnr_{key}" in row]
    text = "; PSNR " + ", ".join(parts) if parts else ""
    if "psnr_simulated" in row:
        text += (f"; the simulated pipeline's output {row['psnr_simulated']:.2f} dB (real - simulated "
                 f"{row['psnr_output_minus_simulated']:+.2f} dB)")
    return text


def _variant() -> str:
    import mitsuba as mi

    return str(mi.variant())

"""Input (b) of ``mcd.denoise``: a Mitsuba scene, rendered and sampled for real (docs/denoise.md, "Scenes:
the real loop"; docs/method.md "Adaptive sampling"; paper Sec. 3.1).

Per frame (the scene's own camera; with ``frames > 1`` a path derived from it as for the benchmark's scenes,
:func:`mcd.data.scenes.derive_nodes`): render ``c_1`` (1 spp, ``N`` samples) and the G-buffers (their own
samples, not part of the colour budget, as in the benchmark), run the sampling network ``F_s``, normalise its
map to exactly ``N * (s - 1)`` samples, render those per-pixel counts with Mitsuba
(:func:`mcd.data.spp_map_render.render_spp_map`, injected through :func:`mcd.sampling.real_renderer`), then
the second stage. Colour samples per frame: ``N + N * (s - 1) = N * s`` exactly (checked). A uniform method
renders ``c_s`` (``N * s``) instead. NTASAD's first frame also reads ``c_s`` (its stand-in for a previous
output), rendered on top and reported apart.

With ``reference_spp``, a reference and the stack ``c_1 .. c_{2^levels}`` of the simulated render are
rendered too, a copy of the model runs the simulated pipeline (what the benchmark measures), and the PSNR of
both against the reference is reported with their difference (real minus simulated).
"""

from __future__ import annotations

import copy
import logging
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

from mcd.data.buffers import GBUFFERS, uniform_buffer
from mcd.data.camera import Camera, backward_motion, interpolate_path
from mcd.data.exposure import auto_exposure, depth_scale, normalise
from mcd.data.renderer import derive_seed
from mcd.data.scenes import SceneNotFoundError, SceneSpec, path_scene_name
from mcd.denoise.output import hwc, write_frame
from mcd.denoise.precision import layout, prepare, running
from mcd.denoise.weights import Loaded
from mcd.metrics import psnr
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


def denoise_scene(loaded_model: Loaded, path: Path, out_dir: Path, device: torch.device, width: int,
                  height: int, frames: int = 1, gbuffer_spp: int = 16, seed: int = 0,
                  reference_spp: int = 0, progress: bool = True,
                  dtype: torch.dtype | None = None) -> dict[str, Any]:
    """Render and denoise ``path`` (module docstring) with autocast to ``dtype`` (None: fp32;
    mcd/denoise/precision.py); returns a summary with per-frame samples and PSNRs."""
    from mcd.data.mitsuba_env import select_variant
    from mcd.data.renderer import SceneRenderer

    select_variant("auto")
    cfg = loaded_model.cfg
    model = prepare(loaded_model.model.to(device), dtype)
    budget = int(cfg.budget)
    levels = int((cfg.method.get("sampling", None) or {}).get("levels", 5))
    reads = set(model.required_buffers())
    scene, cams = load_scene(path, width, height, cfg.data.get("max_depth"), frames)
    r = SceneRenderer(scene.scene, width, height, scene.fov)
    n = width * height
    target = float(cfg.data.get("exposure_target", 0.5))
    sim_model = copy.deepcopy(model) if reference_spp and loaded_model.adaptive else None
    exposure = scale = 1.0
    rows: list[dict[str, Any]] = []
    model.reset()
    if sim_model is not None:
        sim_model.reset()
    t0 = time.perf_counter()
    prev_cam: Camera | None = None

    def colour(spp: int, key: str, f: int) -> np.ndarray:
        """A render of frame ``f`` at ``spp`` (not part of the budget), normalised as the network's inputs."""
        return normalise(r.color(spp, derive_seed(seed, key, f)), key, exposure, scale, colour=True)[0]

    for f, to_world in enumerate(tqdm(cams, desc=f"denoise {path.name}", unit="frame", disable=not progress)):
        r.set_camera(to_world)
        cam = r.camera(to_world)
        spent = {"c1": 0, "adaptive": 0, "uniform": 0, "extra": 0}
        raw: dict[str, np.ndarray] = {}
        if loaded_model.adaptive:
            raw["c1_in"] = r.color(1, derive_seed(seed, "c1_in", f))
            spent["c1"] = n
        uniform = uniform_buffer(budget)
        if uniform in reads and (not loaded_model.adaptive or f == 0):
            raw[uniform] = r.color(budget, derive_seed(seed, uniform, f))
            spent["uniform" if not loaded_model.adaptive else "extra"] = n * budget
        gb = r.gbuffer(gbuffer_spp, derive_seed(seed, "gbuffer", f))
        if f == 0:
            exposure = auto_exposure(raw.get("c1_in", raw.get(uniform)), target) or 1.0
            scale = depth_scale(gb["depth"])
        x: dict[str, torch.Tensor | None] = {}
        for name, img in {**raw, **{b: gb[b] for b in GBUFFERS if b in reads}}.items():
            x[name] = layout(_tensor(normalise(img, name, exposure, scale, colour=name not in GBUFFERS)[0],
                                     device), dtype)
        if "motion" in reads:
            mv = (np.zeros((height, width, 2), np.float32) if prev_cam is None
                  else backward_motion(gb["depth"], cam, prev_cam))
            x["motion"] = layout(_tensor(mv, device), dtype)
        prev_cam = cam
        row: dict[str, Any] = {"frame": f}
        with running(device, dtype):
            if loaded_model.adaptive:
                placeholders = {k: torch.zeros_like(x["c1_in"]) for k in stack_names(levels)}
                render = AdaptiveRender(scene.scene, r.sensor, derive_seed(seed, "adaptive", f), exposure)
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
        if reference_spp:
            ref = colour(reference_spp, "ref", f)
            noisy = out["adaptive"] if "adaptive" in out else x[uniform]
            row.update(psnr_input=psnr(hwc(noisy), ref), psnr_real=psnr(hwc(out["output"]), ref))
            if sim_model is not None:
                stack = {k: layout(_tensor(colour(2 ** j, k, f), device), dtype)
                         for j, k in enumerate(stack_names(levels))}
                with running(device, dtype):
                    sim = sim_model({**x, **stack})
                row["psnr_simulated"] = psnr(hwc(sim["output"]), ref)
                row["psnr_real_minus_simulated"] = row["psnr_real"] - row["psnr_simulated"]
        write_frame(out_dir, f"{scene.spec.name}_{f:04d}", out, exposure)
        rows.append(row)
    return {"frames": rows, "size": [height, width], "budget": budget, "exposure": exposure,
            "seconds": time.perf_counter() - t0, "out_dir": str(out_dir), "variant": _variant()}


def _variant() -> str:
    import mitsuba as mi

    return str(mi.variant())

"""Mitsuba rendering of one scene's frames (docs/benchmark.md, "Data protocol"; docs/data.md, "Rendering").

Every render uses a sensor built here: the frame's camera, the profile's film size and a **box** pixel filter
(so every pixel's samples are its own), whatever filter the scene file declares. Colour comes from the scene's
own integrator; G-buffers from the ``aov`` integrator (``dd.y:depth,nn:sh_normal,alb:albedo``: first-hit
distance, shading normal, albedo; docs/data.md), averaged over ``gbuffer_spp`` samples per pixel by the box
filter. Albedo is 0 on smooth glass and mirrors (no diffuse first hit): expected.

A render with more samples than ``max_samples_per_pass`` (LLVM/CUDA wavefront memory) is split into passes
with their own seeds and averaged with weights proportional to their sample counts, which is the same
estimator.
"""

from __future__ import annotations

import hashlib
from typing import Any

import numpy as np

from mcd.data.camera import Camera

AOVS = "dd.y:depth,nn:sh_normal,alb:albedo"


def derive_seed(*parts: object) -> int:
    """A reproducible 31-bit seed from (data seed, scene, frame, buffer, pass): independent per image."""
    digest = hashlib.blake2b("/".join(map(str, parts)).encode(), digest_size=8).digest()
    return int.from_bytes(digest, "little") & 0x7FFFFFFF


class SceneRenderer:
    """Renders colour at a given spp and G-buffers for the frames of one loaded scene."""

    def __init__(self, scene: Any, width: int, height: int, fov: float, max_samples_per_pass: int = 1 << 24):
        import mitsuba as mi

        self.mi = mi
        self.scene = scene
        self.width, self.height, self.fov = int(width), int(height), float(fov)
        self.max_samples = int(max_samples_per_pass)
        self.sensor = mi.load_dict(
            {
                "type": "perspective",
                "fov": self.fov,
                "fov_axis": "x",
                "near_clip": _near_clip(scene),
                "to_world": mi.ScalarTransform4f(),
                "film": {
                    "type": "hdrfilm",
                    "width": self.width,
                    "height": self.height,
                    "rfilter": {"type": "box"},
                    "pixel_format": "rgb",
                },
                "sampler": {"type": "independent", "sample_count": 1},
            }
        )
        self._params = mi.traverse(self.sensor)
        self.to_world = np.eye(4)
        self._aov = mi.load_dict({"type": "aov", "aovs": AOVS})
        self.samples_rendered = 0

    def camera(self, to_world: np.ndarray) -> Camera:
        return Camera(np.asarray(to_world, dtype=np.float64), self.fov, self.width, self.height)

    def set_camera(self, to_world: np.ndarray) -> None:
        """Move the sensor to the camera transform `to_world` (4x4) for the next renders."""
        self.to_world = np.asarray(to_world, dtype=np.float64)
        self._params["to_world"] = self.mi.ScalarTransform4f(np.ascontiguousarray(to_world, dtype=np.float32))
        self._params.update()

    def _render(self, spp: int, seed: int, integrator: Any = None) -> np.ndarray:
        px = self.width * self.height
        n_pass = max(1, -(-spp * px // self.max_samples))
        per = [spp // n_pass + (1 if i < spp % n_pass else 0) for i in range(n_pass)]
        acc = None
        for i, s in enumerate(per):
            if s == 0:
                continue
            pass_seed = seed if n_pass == 1 else derive_seed(seed, "pass", i)
            img = np.asarray(
                self.mi.render(self.scene, sensor=self.sensor, integrator=integrator, spp=s, seed=pass_seed),
                dtype=np.float32,
            )
            acc = img * (s / spp) if acc is None else acc + img * (s / spp)
        self.samples_rendered += spp * px
        return acc

    def color(self, spp: int, seed: int) -> np.ndarray:
        """An independent render at `spp` samples per pixel, ``(H, W, 3)`` linear radiance."""
        return self._render(spp, seed)[..., :3]

    def gbuffer(self, spp: int, seed: int) -> dict[str, np.ndarray]:
        """First-hit ``depth`` (H, W, 1), ``normal`` and ``albedo`` (H, W, 3): box-filtered means."""
        img = self._render(spp, seed, integrator=self._aov)
        return {"depth": img[..., 0:1], "normal": img[..., 1:4], "albedo": img[..., 4:7]}


def _near_clip(scene: Any) -> float:
    """A near clip small against the scene (Mitsuba's default of 0.01 is too large for a 1-unit box)."""

    bbox = scene.bbox()
    extent = float(
        np.linalg.norm(np.asarray(bbox.max, dtype=np.float64) - np.asarray(bbox.min, dtype=np.float64))
    )
    return float(min(1e-2, max(1e-5, 1e-4 * extent))) if np.isfinite(extent) else 1e-2

"""The true adaptive Mitsuba render of a sampling map (docs/method.md, "Adaptive sampling" step 5).

Pixel ``p`` gets exactly ``spp_map[p]`` independent samples and its value is their mean (a box filter: every
sample lands in its own pixel), which is what the simulated render ``sum_k c_{2^k} 2^k bit_k(m) / m`` of
:mod:`mcd.sampling.simulate` estimates from the stored stack. Used to validate that simulation.

JIT variants (LLVM, CUDA) trace one wavefront of ``sum(spp_map)`` camera rays (``sensor.sample_ray`` then
``integrator.sample``) and scatter-add each sample into its pixel. The scalar variant renders the frame once
per distinct count ``k`` at ``k`` spp (own seed) and keeps the pixels whose count is ``k``: the same
estimator, slower.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mcd.data.renderer import derive_seed


def _check_map(spp_map: np.ndarray, width: int, height: int) -> np.ndarray:
    m = np.asarray(spp_map)
    if m.shape != (height, width):
        raise ValueError(f"spp_map of shape {m.shape} does not match the {height}x{width} film")
    if not np.all(np.isfinite(m)) or np.any(m < 0) or np.any(m != np.round(m)):
        raise ValueError("spp_map must hold non-negative integer sample counts")
    return m.astype(np.int64)


def render_spp_map(scene: Any, spp_map: np.ndarray, seed: int, sensor: Any = None) -> np.ndarray:
    """Render `scene` with ``spp_map[y, x]`` samples in pixel (x, y): ``(H, W, 3)`` float32, 0 at count 0.

    `sensor` defaults to the scene's first sensor (its film size must match the map; its pixel filter is not
    used: samples are box-filtered by construction).
    """
    import drjit as dr
    import mitsuba as mi

    sensor = sensor if sensor is not None else scene.sensors()[0]
    film = sensor.film()
    width, height = (int(v) for v in film.crop_size())
    m = _check_map(spp_map, width, height)
    total = int(m.sum())
    if total == 0:
        return np.zeros((height, width, 3), np.float32)
    if not mi.variant().startswith(("llvm", "cuda")):
        return _render_by_level(scene, sensor, m, seed)
    sampler = sensor.sampler().clone()
    sampler.seed(seed, total)
    pix = mi.UInt32(np.repeat(np.arange(width * height, dtype=np.uint32), m.ravel()))
    pos = mi.Vector2f(mi.Float(pix % width), mi.Float(pix // width)) + sampler.next_2d()
    offset = mi.ScalarVector2f(film.crop_offset())
    size = mi.ScalarVector2f(film.size())
    ray, weight = sensor.sample_ray(
        time=0.0, sample1=sampler.next_1d(), sample2=(pos + offset) / size, sample3=sampler.next_2d()
    )
    radiance, _, _ = scene.integrator().sample(scene, sampler, ray, None, True)
    value = radiance * weight
    acc = dr.zeros(mi.Float, width * height * 3)
    for c in range(3):
        dr.scatter_reduce(dr.ReduceOp.Add, acc, value[c], pix * 3 + c)
    img = np.asarray(acc, dtype=np.float64).reshape(height, width, 3)
    return (img / np.maximum(m, 1)[..., None]).astype(np.float32)


def _render_by_level(scene: Any, sensor: Any, m: np.ndarray, seed: int) -> np.ndarray:
    import mitsuba as mi

    out = np.zeros((*m.shape, 3), np.float32)
    for k in np.unique(m):
        if k == 0:
            continue
        img = np.asarray(mi.render(scene, sensor=sensor, spp=int(k), seed=derive_seed(seed, "level", int(k))))
        out[m == k] = img[..., :3][m == k]
    return out

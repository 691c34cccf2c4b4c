"""``python -m mcd.check_paths data=<profile>``: no camera-path frame is rendered from inside a wall.

Renders every frame of every scene of the profile at a low resolution and spp (:func:`check_scene`'s
``size`` and ``spp``, 24x24 at 16 spp; no config key changes them) with colour and first-hit depth, and
flags a frame that is mostly black (its fraction of black pixels exceeds frame 0's, the scene's own camera,
by 0.25), one colour (luminance varies by less than 2% across a frame that is not mostly black) or much
closer to geometry than frame 0 (median depth under 5% of frame 0's): the signs of a camera inside or
against a wall (docs/scenes.md, "Using them"). Exits non-zero when a frame is flagged.
"""

from __future__ import annotations

import logging
import sys

import numpy as np
from omegaconf import DictConfig

from mcd.config.compose import hydra_main
from mcd.data.camera import interpolate_path
from mcd.data.renderer import SceneRenderer
from mcd.data.scenes import SceneSpec

log = logging.getLogger("mcd.check_paths")


def frame_stats(img: np.ndarray, depth: np.ndarray) -> tuple[float, float, float]:
    """(fraction of black pixels, relative spread of luminance, median first-hit depth) of one frame."""
    lum = img[..., :3].mean(-1)
    black = float((lum < 1e-3 * max(float(lum.mean()), 1e-6) + 1e-6).mean())
    spread = float(lum.std() / max(float(lum.mean()), 1e-9))
    hit = depth[depth > 0]
    return black, spread, float(np.median(hit)) if hit.size else float("inf")


def check_scene(
    spec: SceneSpec,
    segments: int,
    frames_per_segment: int,
    size: int = 24,
    spp: int = 16,
    max_depth: int | None = 6,
    stride: int = 1,
) -> list[str]:
    """Problems found on the scene's camera path (empty when every frame looks like the inside of a room)."""
    loaded = spec.load(size, size, max_depth, segments)
    r = SceneRenderer(loaded.scene, size, size, loaded.fov)
    problems = []
    base: tuple[float, float, float] | None = None
    for f, m in enumerate(interpolate_path(loaded.nodes, frames_per_segment)):
        if f % stride:
            continue
        r.set_camera(m)
        img = r.color(spp, seed=f)
        depth = r.gbuffer(4, seed=f)["depth"][..., 0]
        black, spread, med = frame_stats(img, depth)
        if base is None:
            base = (black, spread, med)
        if black > base[0] + 0.25:
            problems.append(f"{spec.name} frame {f}: {black:.0%} black pixels (frame 0: {base[0]:.0%})")
        if spread < 0.02 and black < 0.5:  # (an all-black frame is judged by the black and depth tests)
            problems.append(f"{spec.name} frame {f}: one colour (luminance spread {spread:.3f})")
        if np.isfinite(base[2]) and med < 0.05 * base[2]:
            problems.append(f"{spec.name} frame {f}: median depth {med:.3g} against frame 0's {base[2]:.3g}")
    return problems


@hydra_main
def main(cfg: DictConfig) -> None:
    from mcd.data.mitsuba_env import select_variant
    from mcd.data.store import StoreReader

    select_variant(str(cfg.render.get("variant", "auto")))
    store = StoreReader.from_cfg(cfg)
    problems = []
    for name in store.scene_names:
        found = check_scene(store.specs[name], int(cfg.data.segments), int(cfg.data.frames_per_segment))
        log.info("%s: %s", name, "ok" if not found else f"{len(found)} suspicious frames")
        problems += found
    for p in problems:
        log.error(p)
    if problems:
        sys.exit(1)


if __name__ == "__main__":
    main()

"""``python -m mcd.denoise.render_frames <scene.xml> <folder>``: render a noisy EXR sequence in the format
``mcd-denoise`` reads (docs/denoise.md, "Frames from disk"), to try input (a) without a renderer of your own.

Each frame ``<folder>/<scene>_<frame:04d>.exr`` holds the colour at ``--spp`` samples per pixel and the
G-buffers as layers (``--siblings``: as sibling files); ``--reference-spp`` also writes a reference of each
frame under ``<folder>/reference/`` (not read as a frame). The camera follows the path derived from the
scene's own camera (docs/scenes.md, "Camera paths"); every render has its own seed.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from mcd.data.buffers import GBUFFERS
from mcd.data.renderer import derive_seed
from mcd.denoise import arguments
from mcd.denoise.frames import write_layers


def render_frames(scene_file: Path, out_dir: Path, frames: int = 4, spp: int = 4, width: int = 128,
                  height: int = 128, gbuffer_spp: int = 16, reference_spp: int = 0, seed: int = 0,
                  max_depth: int | None = 8, siblings: bool = False,
                  camera_path: dict[str, Any] | None = None) -> list[Path]:
    """Render the sequence (module docstring); returns the colour frames written, in order.

    ``camera_path``: ``dolly``, ``truck``, ``pan_deg`` of the derived path (docs/scenes.md, "Camera paths").
    """
    from mcd.data.mitsuba_env import select_variant
    from mcd.data.renderer import SceneRenderer
    from mcd.denoise.scene import load_scene

    select_variant("auto")
    loaded, cams = load_scene(scene_file, width, height, max_depth, frames, camera_path)
    r = SceneRenderer(loaded.scene, width, height, loaded.fov)
    written = []
    for f, cam in enumerate(cams):
        r.set_camera(cam)
        colour = r.color(spp, derive_seed(seed, "colour", f))
        gb = r.gbuffer(gbuffer_spp, derive_seed(seed, "gbuffer", f))
        path = out_dir / f"{loaded.spec.name}_{f:04d}.exr"
        if siblings:
            write_layers(path, colour)
            for name in GBUFFERS:
                sibling = path.with_name(f"{path.stem}.{name}.exr")
                write_layers(sibling, np.zeros_like(colour), {name: gb[name]})
        else:
            write_layers(path, colour, gb)
        if reference_spp:
            ref = r.color(reference_spp, derive_seed(seed, "ref", f))
            write_layers(out_dir / "reference" / path.name, ref)
        written.append(path)
    return written


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python -m mcd.denoise.render_frames",
                                description=__doc__.split("\n\n")[0], formatter_class=arguments.HelpFormatter)
    p.add_argument("scene", type=arguments.scene_file, help="a Mitsuba 3 scene file")
    p.add_argument("folder", type=Path, help="output folder of the EXR frames")
    p.add_argument("--frames", type=arguments.int_in(1, 10**5), default=4, help="frames to render")
    p.add_argument("--spp", type=arguments.int_in(1, 2**16), default=4,
                   help="samples per pixel of the noisy colour")
    p.add_argument("--width", type=arguments.side, default=128, help="film width")
    p.add_argument("--height", type=arguments.side, default=128, help="film height")
    p.add_argument("--gbuffer-spp", type=arguments.int_in(1, 2**16), default=16,
                   help="samples per pixel of the G-buffers")
    p.add_argument("--reference-spp", type=arguments.int_in(0, 2**20), default=0,
                   help="also write references at this spp; 0: none")
    p.add_argument("--seed", type=arguments.int_in(0, 2**32 - 1), default=0, help="render seed")
    p.add_argument("--siblings", action="store_true", help="G-buffers as sibling files, not layers")
    p.add_argument("--dolly", type=arguments.float_in(-10, 10), default=0.3,
                   help="camera path: forward share of the free distance")
    p.add_argument("--truck", type=arguments.float_in(-10, 10), default=0.15,
                   help="camera path: sideways share of the free distance")
    p.add_argument("--pan-deg", type=arguments.float_in(-360, 360), default=10.0,
                   help="camera path: pan in degrees")
    a = p.parse_args(argv)
    path = {"dolly": a.dolly, "truck": a.truck, "pan_deg": a.pan_deg}
    paths = render_frames(a.scene, a.folder, a.frames, a.spp, a.width, a.height, a.gbuffer_spp,
                          a.reference_spp, a.seed, siblings=a.siblings, camera_path=path)
    print(f"{len(paths)} frames -> {a.folder}")


if __name__ == "__main__":
    main()

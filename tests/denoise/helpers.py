"""Real inputs for the ``mcd.denoise`` tests: a 32x32 Cornell-box sequence rendered with Mitsuba and written
as EXR frames, and bundles of real (untrained) models written by :func:`mcd.denoise.bundle.write_bundle`."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np

from mcd.denoise.frames import write_layers
from tests.conftest import compose_cfg

REPO = Path(__file__).resolve().parents[2]
SIZE = 32


def render_sequence(folder: Path, frames: int = 3, spp: int = 4, ref_spp: int = 0,
                    siblings: bool = False) -> list[np.ndarray]:
    """Render cbox at 32x32 along its camera path: ``<folder>/f000k.exr`` (colour at ``spp`` + G-buffers as
    layers, or as sibling files), returns the references at ``ref_spp`` (empty when 0)."""
    from mcd.data.camera import interpolate_path
    from mcd.data.mitsuba_env import select_variant
    from mcd.data.renderer import SceneRenderer
    from mcd.data.scenes import VENDORED_DIR, SceneSpec

    select_variant("auto")
    spec = SceneSpec("cbox", "xml", file=VENDORED_DIR / "cbox" / "scene.xml",
                     path={"dolly": 0.45, "truck": 0.04, "pan_deg": 2})
    loaded = spec.load(SIZE, SIZE, 8, 1)
    r = SceneRenderer(loaded.scene, SIZE, SIZE, loaded.fov)
    refs = []
    for f, cam in enumerate(interpolate_path(loaded.nodes, frames)):
        r.set_camera(cam)
        colour = r.color(spp, seed=100 + f)
        gb = r.gbuffer(8, seed=200 + f)
        path = folder / f"f{f:04d}.exr"
        if siblings:
            write_layers(path, colour)
            for name in ("albedo", "normal", "depth"):
                sibling = path.with_name(f"{path.stem}.{name}.exr")
                write_layers(sibling, np.zeros_like(colour), {name: gb[name]})
        else:
            write_layers(path, colour, gb)
        if ref_spp:
            refs.append(r.color(ref_spp, seed=300 + f))
    return refs


def untrained_bundle(folder: Path, name: str, *overrides: str) -> Path:
    """A bundle of the freshly built model of ``overrides`` (``+experiment=unet``, ...) as
    ``<folder>/<name>.pt``."""
    from mcd.denoise.bundle import write_bundle
    from mcd.models import build

    cfg = compose_cfg("data=small", *overrides)
    write_bundle(build(cfg).state_dict(), cfg, name, {"command": "untrained, for tests"}, folder)
    return folder / f"{name}.pt"


def console_script(*args: str) -> subprocess.CompletedProcess:
    """Run ``mcd-denoise`` as its console script does: the entry point pyproject.toml declares, called by
    ``sys.exit(main())`` in a fresh interpreter with this checkout first on the path."""
    target = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["scripts"]["mcd-denoise"]
    module, func = target.split(":")
    code = f"import sys; from {module} import {func}; sys.exit({func}(sys.argv[1:]))"
    env = {**os.environ, "PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True, env=env,
                          cwd=REPO, timeout=600)

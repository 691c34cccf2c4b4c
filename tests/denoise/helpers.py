"""Real inputs for the ``mcd.denoise`` tests: a 32x32 Cornell-box sequence rendered with Mitsuba and written
as EXR frames, and bundles of real (untrained) models written by :func:`mcd.bundle.write_bundle`."""

from __future__ import annotations

import os
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
from omegaconf import OmegaConf

from tests.conftest import compose_cfg

REPO = Path(__file__).resolve().parents[2]
SIZE = 32


def render_sequence(folder: Path, frames: int = 3, spp: int = 4, ref_spp: int = 0,
                    siblings: bool = False, size: int = SIZE) -> list[np.ndarray]:
    """Cornell box at ``size`` x ``size`` (32) along its benchmark camera path (``conf/scene/cbox.yaml``),
    written by ``mcd.denoise.render_frames`` as ``<folder>/cbox_000k.exr``; returns the references at
    ``ref_spp``."""
    from mcd.data.scenes import VENDORED_DIR
    from mcd.denoise.frames import read_channels
    from mcd.denoise.render_frames import render_frames

    camera = OmegaConf.to_container(OmegaConf.load(REPO / "conf" / "scene" / "cbox.yaml").path)
    paths = render_frames(VENDORED_DIR / "cbox" / "scene.xml", folder, frames, spp, size, size, gbuffer_spp=8,
                          reference_spp=ref_spp, siblings=siblings, camera_path=camera)
    refs = []
    for p in paths if ref_spp else []:
        chans = read_channels(folder / "reference" / p.name)
        refs.append(np.stack([chans[c] for c in "RGB"], -1))
    return refs


def untrained_bundle(folder: Path, name: str, *overrides: str) -> Path:
    """A bundle of the freshly built model of ``overrides`` (``+experiment=unet``, ...) as
    ``<folder>/<name>.pt``."""
    from mcd.bundle import write_bundle
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

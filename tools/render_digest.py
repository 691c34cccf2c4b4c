"""``python tools/render_digest.py``: SHA-256 digests of each vendored scene's render at a fixed seed, to
check that a render is reproducible (docs/data.md, "Reproducible renders").

For every scene registered with ``vendored: true`` in ``conf/scene/`` (and, with ``--procedural``, the
procedural room of ``conf/scene/procedural.yaml``) the scene is loaded as the store loads it
(:meth:`mcd.data.scenes.SceneSpec.load`), its own camera is set, and the colour is rendered at ``--spp`` with
the seed :func:`mcd.data.renderer.derive_seed` gives ``(seed, scene, "colour")``; the digest is of the float32
image's bytes. Two processes (or two machines) that print the same digests rendered bit-identical images.
``--threads N`` sets Dr.Jit's thread count first, to check that the thread count does not change a render.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os

from mcd.core.paths import CONF_DIR


def digest_scenes(procedural: bool = False) -> list[str]:
    """The scene configs whose renders are digested: the vendored ones, sorted (and ``procedural``)."""
    from omegaconf import OmegaConf

    names = sorted(p.stem for p in (CONF_DIR / "scene").glob("*.yaml")
                   if OmegaConf.load(p).get("vendored", False))
    return names + (["procedural"] if procedural else [])


def render_digests(names: list[str], width: int = 128, height: int = 128, spp: int = 2, seed: int = 0,
                   threads: int | None = None, scenes_dir: str | None = None) -> dict[str, str]:
    """``{scene: sha256 of its float32 (H, W, 3) colour render}`` for the scene configs ``names``
    (``scenes_dir``: the folder of the scenes that are not vendored, as ``paths.scenes_dir``)."""
    import numpy as np
    from omegaconf import OmegaConf

    from mcd.data.mitsuba_env import select_variant
    from mcd.data.renderer import SceneRenderer, derive_seed
    from mcd.data.scenes import SceneSpec

    select_variant("auto")
    if threads is not None:
        import drjit as dr

        dr.set_thread_count(threads)
    out = {}
    for name in names:
        cfg = OmegaConf.load(CONF_DIR / "scene" / f"{name}.yaml")
        loaded = SceneSpec.from_cfg(name, cfg, scenes_dir).load(width, height, 8, segments=1)
        r = SceneRenderer(loaded.scene, width, height, loaded.fov)
        r.set_camera(loaded.nodes[0])
        img = np.ascontiguousarray(r.color(spp, derive_seed(seed, name, "colour")), dtype=np.float32)
        out[name] = hashlib.sha256(img.tobytes()).hexdigest()
    return out


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="python tools/render_digest.py", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.ArgumentDefaultsHelpFormatter)
    p.add_argument("--size", type=int, default=128, help="film width and height in pixels")
    p.add_argument("--spp", type=int, default=2, help="samples per pixel")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--threads", type=int, default=None, help="Dr.Jit thread count (default: its own)")
    p.add_argument("--procedural", action="store_true", help="also the procedural room (seed 0)")
    p.add_argument("--scene", action="append", default=None,
                   help="a scene config name of conf/scene/ (repeatable; default: the vendored ones)")
    p.add_argument("--scenes-dir", default=os.environ.get("MCD_SCENES_DIR"),
                   help="folder of the scenes that are not vendored (default: $MCD_SCENES_DIR)")
    a = p.parse_args(argv)
    names = a.scene or digest_scenes(a.procedural)
    print(json.dumps(render_digests(names, a.size, a.size, a.spp, a.seed, a.threads, a.scenes_dir), indent=1))


if __name__ == "__main__":
    main()

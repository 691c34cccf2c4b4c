"""A synthetic EXR store in the real store's layout, for measuring and testing the data path at shapes no
render on a small machine reaches (the loader bench at 1920x1080, docs/training_store.md; the paper-shaped
smoke test, tests/scale/).

:func:`write_synthetic_store` writes ``<data_dir>/<profile>/<scene>/<frame:04d>/<buffer>.exr`` exactly as
:class:`mcd.data.store_builder.StoreBuilder` does (colour uncompressed, the others ZIP, atomic writes) from
:func:`mcd.data.synthetic.synthetic_frame`'s seeded values (incompressible noise in colour), and a manifest
with each file's real size, SHA-256 and NaN / Inf / negative counts, a still camera per frame, exposure 1 and
depth scale 1. :class:`mcd.data.store.StoreReader` and the datamodule read it like a rendered store; it has no
render keys, so ``StoreBuilder.ensure`` would render it again: build readers on it, not builders.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path

import numpy as np
from omegaconf import DictConfig, OmegaConf

from mcd.data.buffers import BUFFERS, COLOUR_BUFFERS, NEGATIVE_OK
from mcd.data.camera import Camera
from mcd.data.exr import count_bad, sha256, write_exr
from mcd.data.synthetic import synthetic_frame


def synthetic_data_cfg(profile: str, scene: str, width: int, height: int, frames: int, clip_len: int = 5,
                       val_clips: int = 0) -> DictConfig:
    """A data profile (``data.*``) of one procedural-named scene of ``frames`` frames: one test frame, then
    ``val_clips`` validation clips, the rest training clips."""
    return OmegaConf.create({
        "name": profile, "width": width, "height": height, "segments": 1, "frames_per_segment": frames,
        "test_fraction": 1.0 / frames, "val_clips": val_clips, "clip_len": clip_len, "train_crop": 256,
        "train_crop_at_edge": 0.0, "val_crop": 512, "num_workers": 0, "cache_in_memory": False,
        "verify_checksums": False, "scenes": {scene: {"kind": "procedural", "seed": 0}},
        "train_scenes": [scene], "transfer_scenes": [], "test_scenes": [scene],
    })


def write_synthetic_store(data_dir: Path, data_cfg: DictConfig, buffers: Iterable[str],
                          seed: int = 0) -> None:
    """Write the scenes ``data_cfg`` uses (its train, transfer and test lists; e.g.
    :func:`synthetic_data_cfg`) with ``buffers`` into ``data_dir`` (module docstring). Frame ``f`` of a scene
    is drawn with seed ``seed + f``."""
    want = [b for b in BUFFERS if b in set(buffers)]
    h, w = int(data_cfg.height), int(data_cfg.width)
    n = int(data_cfg.segments) * int(data_cfg.frames_per_segment)
    cam = Camera(np.eye(4), 40.0, w, h).to_dict()
    lists = ("train_scenes", "transfer_scenes", "test_scenes")
    for scene in dict.fromkeys(s for key in lists for s in data_cfg.get(key) or []):
        root = Path(data_dir) / str(data_cfg.name) / str(scene)
        files: dict[str, dict] = {}
        for f in range(n):
            frame = synthetic_frame(want, h, w, lead=(), seed=seed + f)
            for b in want:
                img = frame[b].permute(1, 2, 0).numpy()
                p = root / f"{f:04d}" / f"{b}.exr"
                write_exr(p, img, compress=b not in COLOUR_BUFFERS)
                files[f"{f:04d}/{b}.exr"] = {"bytes": p.stat().st_size, "sha256": sha256(p),
                                             **count_bad(img, b in NEGATIVE_OK)}
        manifest = {"scene": str(scene), "profile": str(data_cfg.name), "synthetic": True,
                    "cameras": [cam] * n, "exposure": 1.0, "depth_scale": 1.0, "files": files}
        (root / "manifest.json").write_text(json.dumps(manifest, indent=1))

"""Frames on disk for the ``mcd-denoise`` reliability tests: real EXR files in the layout of
docs/denoise.md ("Frames from disk"), written by :func:`mcd.denoise.frames.write_layers`."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mcd.denoise.cli import run
from mcd.denoise.frames import write_layers


def write_frames(folder: Path, n: int = 3, size: tuple[int, int] = (16, 24), seed: int = 0,
                 prefix: str = "f") -> list[Path]:
    """``n`` frames ``<folder>/<prefix>NNNN.exr`` of ``size`` (H, W) with every layer, HDR colour."""
    rng = np.random.default_rng(seed)
    h, w = size
    paths = []
    for i in range(n):
        colour = rng.gamma(0.5, 2.0, (h, w, 3)).astype(np.float32)
        normal = rng.normal(size=(h, w, 3)).astype(np.float32)
        normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
        layers = {"albedo": rng.random((h, w, 3), dtype=np.float32), "normal": normal,
                  "depth": 1 + rng.random((h, w, 1), dtype=np.float32)}
        path = folder / f"{prefix}{i:04d}.exr"
        write_layers(path, colour, layers)
        paths.append(path)
    return paths


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (names relative to it) with its bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def refused(capsys, *argv: str) -> str:
    """Run ``mcd-denoise argv``; assert it exits 2; return its stderr."""
    with pytest.raises(SystemExit) as exc:
        run([*argv, "--no-progress"])
    assert exc.value.code == 2
    return capsys.readouterr().err

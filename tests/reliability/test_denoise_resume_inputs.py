"""Campaign 8 (docs/reliability.md, "Campaign 8, part 2"): ``mcd-denoise`` resumes a frame only if its input
is the one it denoised. The record named each input by its size and modification time alone, so a frame
replaced by another of the same size and time (a copy that keeps times, an archive's fixed times, a file
system's coarse clock) kept the old frame's output: "3 finished before, kept", exit 0. Each input's SHA-256
is now part of the settings a resume compares."""

from __future__ import annotations

import os
import shutil

import numpy as np
import pytest

from mcd.denoise.cli import run
from mcd.denoise.frames import read_channels, write_layers
from tests.reliability.denoise_helpers import write_frames

ARGS = ("--checkpoint", "unet-cpu-small", "--no-progress")


def _albedo_apart(frame) -> None:
    """Move the albedo layer of ``frame`` into its sibling file ``<stem>.albedo.exr``."""
    ch = read_channels(frame)
    rgb = lambda prefix: np.stack([ch[f"{prefix}{c}"] for c in "RGB"], -1)  # noqa: E731
    normal = np.stack([ch[f"normal.{c}"] for c in "XYZ"], -1)
    write_layers(frame, rgb(""), {"normal": normal, "depth": ch["depth.Z"][..., None]})
    write_layers(frame.with_name(f"{frame.stem}.albedo.exr"), rgb("albedo."))


@pytest.mark.parametrize("replaced", ["f0001.exr", "f0001.albedo.exr"])
def test_an_input_replaced_with_the_same_size_and_time_is_denoised_again(tmp_path, replaced):
    frames, other, out, clean = (tmp_path / n for n in ("in", "other", "out", "clean"))
    write_frames(frames, n=3, seed=0)
    write_frames(other, n=3, seed=7)
    if replaced.endswith(".albedo.exr"):  # frame 1's albedo as a sibling file, in both sequences
        for folder in (frames, other):
            _albedo_apart(folder / "f0001.exr")
    run([str(frames), "-o", str(out), *ARGS])
    before = (out / "f0001.exr").read_bytes()
    target = frames / replaced
    stamp = os.stat(target)
    assert os.stat(other / replaced).st_size == stamp.st_size
    shutil.copyfile(other / replaced, target)
    os.utime(target, ns=(stamp.st_atime_ns, stamp.st_mtime_ns))        # same size, same time, other bytes
    report = run([str(frames), "-o", str(out), *ARGS])
    assert report["resumed"] == [], "an output of the replaced input was kept"
    run([str(frames), "-o", str(clean), *ARGS])
    assert (out / "f0001.exr").read_bytes() == (clean / "f0001.exr").read_bytes() != before

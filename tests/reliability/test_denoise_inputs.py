"""``mcd-denoise`` checks every input frame before the first is denoised, and names the bad one
(docs/reliability.md, "Denoising your frames"; mcd/denoise/frames.py, mcd/data/exr.py). Real EXR files,
damaged as a disk, a copy or an attacker would."""

from __future__ import annotations

import resource
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mcd.denoise.cli import run
from mcd.denoise.frames import write_layers
from tests.denoise.helpers import REPO, untrained_bundle
from tests.reliability.denoise_helpers import refused, snapshot, write_frames

NOISY = ("--experiment", "noisy")


@pytest.fixture(scope="module")
def unet(tmp_path_factory) -> Path:
    return untrained_bundle(tmp_path_factory.mktemp("bundles"),
                            "unet-rel", "+experiment=unet", "capacity=cpu")


def bomb(path: Path, good: Path) -> None:
    """``good`` with its header's data window rewritten to 100000 x 100000 pixels (a few KB on disk)."""
    data = bytearray(good.read_bytes())
    at = data.index(b"dataWindow\0box2i\0") + len(b"dataWindow\0box2i\0") + 4
    data[at:at + 16] = struct.pack("<4i", 0, 0, 99999, 99999)
    path.write_bytes(bytes(data))


def damage(kind: str, path: Path) -> None:
    """Make the frame ``path`` bad in one of the ways a user's folder can hold."""
    if kind == "truncated":
        path.write_bytes(path.read_bytes()[: path.stat().st_size // 2])
    elif kind == "zero_bytes":
        path.write_bytes(b"")
    elif kind == "garbage":
        path.write_bytes(np.random.default_rng(0).bytes(4096))
    elif kind == "missing_layer":
        write_layers(path, np.ones((16, 24, 3), np.float32), {"normal": np.ones((16, 24, 3), np.float32)})
    elif kind == "other_size":
        write_frames(path.parent, n=1, size=(16, 20), prefix="tmp")
        (path.parent / "tmp0000.exr").rename(path)
    elif kind == "memory_bomb":
        bomb(path, path.parent / "f0000.exr")


@pytest.mark.parametrize("kind", ["truncated", "zero_bytes", "garbage", "missing_layer", "other_size",
                                  "memory_bomb"])
def test_a_bad_frame_among_40_is_named_before_the_first_output(tmp_path, capsys, unet, kind):
    write_frames(tmp_path / "in", n=40)
    damage(kind, tmp_path / "in" / "f0039.exr")
    err = refused(capsys, str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--checkpoint", str(unet))
    assert f"{tmp_path / 'in' / 'f0039.exr'}: " in err
    unreadable = "not a readable EXR"
    assert {"truncated": unreadable, "zero_bytes": unreadable, "garbage": unreadable,
            "missing_layer": "missing layer 'albedo'", "other_size": "frame 39 is 20x16 but frame 0",
            "memory_bomb": "100000x100000"}[kind] in err
    out = tmp_path / "out"
    assert not out.exists() or not [p for p in out.iterdir() if p.suffix in (".exr", ".png")]


def test_a_memory_bomb_header_is_refused_before_its_pixels_are_allocated(tmp_path):
    """Under a 6 GiB address-space limit (the bomb would need 37 GiB per channel), the reader names the
    declared size; before the header check, the allocation failed with 'file has 0 parts'."""
    write_frames(tmp_path, n=1)
    bomb(tmp_path / "bomb.exr", tmp_path / "f0000.exr")
    assert (tmp_path / "bomb.exr").stat().st_size < 20_000
    code = ("import sys; from mcd.data.exr import read_exr\n"
            "try:\n    read_exr(sys.argv[1])\nexcept ValueError as e:\n    print(e)\n")

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (6 << 30, 6 << 30))

    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "bomb.exr")], capture_output=True,
                          text=True, cwd=REPO, env={"PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"},
                          preexec_fn=limit, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "declares a 100000x100000 image" in done.stdout and "MAX_PIXELS" in done.stdout


def test_read_exr_names_a_layered_frames_layout_and_never_advises_deleting_it(tmp_path):
    from mcd.data.exr import EXRLayoutError, read_exr

    path = write_frames(tmp_path, n=1)[0]
    before = path.read_bytes()
    with pytest.raises(EXRLayoutError) as exc:
        read_exr(path)
    msg = str(exc.value)
    assert f"{path}: channels ['B', 'G', 'R', 'albedo.B'" in msg and "exactly the channels Y" in msg
    assert "layered frame" in msg and "mcd.denoise.frames.read_frame" in msg
    assert "delete" not in msg.lower() and "corrupt" not in msg.lower()
    assert path.read_bytes() == before


def test_hidden_exr_files_in_a_folder_are_not_frames(tmp_path, capsys):
    write_frames(tmp_path / "in", n=2)
    (tmp_path / "in" / "._f0000.exr").write_bytes(b"\x00\x05\x16\x07 AppleDouble resource fork")
    (tmp_path / "in" / ".f0001.exr.x1y2.tmp.exr").write_bytes(b"")
    report = run([str(tmp_path / "in"), "-o", str(tmp_path / "out"), *NOISY, "--no-progress"])
    assert report["frames"] == 2
    assert sorted(p.name for p in (tmp_path / "out").glob("*.exr")) == ["f0000.exr", "f0001.exr"]


def test_two_folders_with_the_same_frame_names_are_refused(tmp_path, capsys):
    write_frames(tmp_path / "a", n=2, seed=1)
    write_frames(tmp_path / "b", n=2, seed=2)
    before = snapshot(tmp_path)
    err = refused(capsys, str(tmp_path / "a"), str(tmp_path / "b"), "-o", str(tmp_path / "out"), *NOISY)
    assert f"{tmp_path / 'b' / 'f0000.exr'}: has the name of {tmp_path / 'a' / 'f0000.exr'}" in err
    assert "Denoise the folders apart" in err
    assert snapshot(tmp_path) == before


def test_a_sibling_layer_of_another_size_is_blamed_on_the_layer_file(tmp_path, capsys, unet):
    write_frames(tmp_path / "in", n=2)
    write_layers(tmp_path / "in" / "f0001.exr", np.ones((16, 24, 3), np.float32),
                 {"albedo": np.ones((16, 24, 3), np.float32), "depth": np.ones((16, 24, 1), np.float32)})
    write_layers(tmp_path / "in" / "f0001.normal.exr", np.zeros((8, 24, 3), np.float32),
                 {"normal": np.ones((8, 24, 3), np.float32)})
    err = refused(capsys, str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--checkpoint", str(unet))
    assert f"{tmp_path / 'in' / 'f0001.normal.exr'}: the normal layer is 24x8 but its frame f0001.exr" in err

"""Every refused input of ``mcd-denoise`` names the file and what to do (docs/denoise.md, "Errors"); NaN/Inf
pixels are sanitised with a count. Real EXR files, real Mitsuba scenes, real (untrained) model bundles."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from mcd.data.exr import read_exr, write_exr
from mcd.denoise.cli import run
from mcd.denoise.frames import write_layers
from tests.denoise.helpers import REPO, render_sequence, untrained_bundle


@pytest.fixture(scope="module")
def unet(tmp_path_factory) -> Path:
    return untrained_bundle(tmp_path_factory.mktemp("bundles"),
                            "unet-test", "+experiment=unet", "capacity=cpu")


@pytest.fixture(scope="module")
def frames(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("frames")
    render_sequence(folder, frames=2)
    return folder


def refused(capsys, *argv: str) -> str:
    with pytest.raises(SystemExit) as exc:
        run([*argv, "--no-progress"])
    assert exc.value.code == 2
    return capsys.readouterr().err


def test_missing_layer_names_the_file_and_the_layer(tmp_path, capsys, unet):
    rng = np.random.default_rng(0)
    write_layers(tmp_path / "in" / "a.exr", rng.random((32, 32, 3), dtype=np.float32),
                 {"normal": rng.random((32, 32, 3), dtype=np.float32)})
    err = refused(capsys, str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--checkpoint", str(unet))
    assert "a.exr: missing layer 'albedo'" in err
    assert "a.albedo.exr" in err and "add the layer to every frame" in err


def test_missing_colour_channels(tmp_path, capsys, unet):
    write_exr(tmp_path / "in" / "a.exr", np.ones((32, 32, 1), np.float32))  # one channel, Y
    err = refused(capsys, str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--checkpoint", str(unet))
    assert "a.exr: no colour channels R, G, B" in err


def test_sibling_files_are_read(tmp_path, unet):
    render_sequence(tmp_path / "in", frames=2, siblings=True)
    report = run([str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--checkpoint", str(unet),
                  "--no-progress"])
    assert report["frames"] == 2  # the sibling layer files are not frames
    assert (tmp_path / "out" / "cbox_0001.exr").is_file()
    assert (tmp_path / "out" / "cbox_0001.png").is_file()


def test_layer_of_another_size(tmp_path, capsys, unet):
    rng = np.random.default_rng(1)
    write_layers(tmp_path / "in" / "a.exr", rng.random((32, 32, 3), dtype=np.float32),
                 {"albedo": rng.random((32, 32, 3), dtype=np.float32),
                  "depth": rng.random((32, 32, 1), dtype=np.float32)})
    write_layers(tmp_path / "in" / "a.normal.exr", np.zeros((16, 32, 3), np.float32),
                 {"normal": rng.random((16, 32, 3), dtype=np.float32)})
    err = refused(capsys, str(tmp_path / "in"), "-o", str(tmp_path / "out"), "--checkpoint", str(unet))
    assert "a.normal.exr: the normal layer is 32x16 but its frame a.exr is 32x32" in err


def test_frame_of_another_size(tmp_path, capsys, unet, frames):
    folder = tmp_path / "in"
    for p in sorted(frames.glob("*.exr")):
        (folder / p.name).parent.mkdir(exist_ok=True)
        (folder / p.name).write_bytes(p.read_bytes())
    rng = np.random.default_rng(2)
    write_layers(folder / "cbox_0009.exr", rng.random((24, 32, 3), dtype=np.float32),
                 {k: rng.random((24, 32, c), dtype=np.float32) for k, c in (("albedo", 3), ("normal", 3),
                                                                          ("depth", 1))})
    err = refused(capsys, str(folder), "-o", str(tmp_path / "out"), "--checkpoint", str(unet))
    assert "cbox_0009.exr: frame 2 is 32x24 but frame 0 (cbox_0000.exr) is 32x32" in err


def test_nan_and_inf_pixels_are_sanitised_and_counted(tmp_path, capsys, unet, frames):
    folder = tmp_path / "in"
    from mcd.denoise.frames import read_channels

    chans = read_channels(frames / "cbox_0000.exr")
    colour = np.stack([chans[c] for c in "RGB"], -1)
    colour[3, 4, 0], colour[5, 6, 1], colour[7, 8, 2] = np.nan, np.inf, -np.inf
    layers = {"albedo": np.stack([chans[f"albedo.{c}"] for c in "RGB"], -1),
              "normal": np.stack([chans[f"normal.{c}"] for c in "XYZ"], -1),
              "depth": chans["depth.Z"][..., None]}
    write_layers(folder / "cbox_0000.exr", colour, layers)
    report = run([str(folder), "-o", str(tmp_path / "out"), "--checkpoint", str(unet), "--no-progress"])
    assert report["sanitised"] == {"cbox_0000.exr:colour": 3}
    assert "sanitised: 3 NaN/Inf/negative input values replaced by 0" in capsys.readouterr().out
    assert np.isfinite(read_exr(tmp_path / "out" / "cbox_0000.exr")).all()


def test_checkpoint_of_another_method(tmp_path, capsys, unet, frames):
    err = refused(capsys, str(frames), "-o", str(tmp_path / "out"), "--checkpoint", str(unet),
                  "--experiment", "F")
    assert "a checkpoint of experiment 'unet', not 'F'" in err and "+experiment=F" in err


def test_checkpoint_of_another_capacity(tmp_path, capsys, unet, frames):
    err = refused(capsys, str(frames), "-o", str(tmp_path / "out"), "--checkpoint", str(unet),
                  "--capacity", "paper")
    assert "not those of capacity=paper" in err and "give a checkpoint trained with capacity=paper" in err


def test_weights_that_do_not_fit_their_config(tmp_path, capsys, frames):
    """A bundle whose .pt holds paper-capacity weights, its JSON saying cpu: check_fits names the shapes."""
    paper = untrained_bundle(tmp_path, "paper", "+experiment=unet", "capacity=paper")
    cpu = untrained_bundle(tmp_path, "cpu", "+experiment=unet", "capacity=cpu")
    cpu.write_bytes(paper.read_bytes())
    meta = json.loads(cpu.with_suffix(".json").read_text())  # its JSON written for these bytes (a swap of
    meta["sha256"] = hashlib.sha256(cpu.read_bytes()).hexdigest()  # the .pt alone is refused before)
    cpu.with_suffix(".json").write_text(json.dumps(meta))
    err = refused(capsys, str(frames), "-o", str(tmp_path / "out"), "--checkpoint", str(cpu))
    assert "does not fit this model" in err and "shape differs" in err


def test_adaptive_checkpoint_needs_a_scene(tmp_path, capsys, frames):
    f = untrained_bundle(tmp_path, "f", "+experiment=F", "capacity=cpu")
    err = refused(capsys, str(frames), "-o", str(tmp_path / "out"), "--checkpoint", str(f))
    assert "samples adaptively" in err and "--scene path/to/scene.xml" in err


def test_oidn_without_its_optional_package_says_how_to_install_it(tmp_path, capsys, frames, monkeypatch):
    monkeypatch.setitem(__import__("sys").modules, "pyoidn", None)   # import pyoidn now raises ImportError
    err = refused(capsys, str(frames), "-o", str(tmp_path / "out"), "--experiment", "oidn")
    assert "needs the optional package pyoidn" in err and "pip install" in err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").glob("*.exr"))


def test_unknown_checkpoint_lists_the_bundled_ones(tmp_path, capsys, frames):
    err = refused(capsys, str(frames), "-o", str(tmp_path / "out"), "--checkpoint", "no-such-model")
    assert "--checkpoint=no-such-model: no such file or folder, and not a bundled checkpoint" in err


@pytest.mark.slow
def test_scene_that_does_not_load(tmp_path, capsys):
    f = untrained_bundle(tmp_path, "f", "+experiment=F", "capacity=cpu")
    bad = tmp_path / "broken" / "scene.xml"
    bad.parent.mkdir()
    bad.write_text('<scene version="3.0.0"><sensor type="perspective"/><shape type="obj">'
                   '<string name="filename" value="gone.obj"/></shape></scene>')  # a camera, a missing mesh
    err = refused(capsys, "--scene", str(bad), "-o", str(tmp_path / "out"), "--checkpoint", str(f),
                  "--width", "32", "--height", "32")
    assert f"{bad}: the scene did not load in Mitsuba 3" in err and "docs/scenes.md" in err
    err = refused(capsys, "--scene", str(tmp_path / "nowhere.xml"), "-o", str(tmp_path / "out"),
                  "--checkpoint", str(f))
    assert "nowhere.xml not found; check the path given to --scene" in err


def test_docs_name_the_layers():
    doc = (REPO / "docs" / "denoise.md").read_text()
    for name in ("albedo.R", "normal.X", "depth.Z", "<stem>.albedo.exr"):
        assert name in doc

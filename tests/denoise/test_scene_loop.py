"""Input (b): the paper's pipeline on a real renderer (docs/denoise.md, "Scenes: the real loop"). Cornell
box at 32x32: ``c_1``, ``F_s``, the predicted counts rendered by Mitsuba, the second stage; exactly ``N * s``
colour samples per frame."""

from __future__ import annotations

import numpy as np
import pytest

import mcd.data.spp_map_render as spp_map_render
from mcd.data.exr import read_exr
from mcd.data.renderer import SceneRenderer
from mcd.data.scenes import VENDORED_DIR
from mcd.denoise.cli import run
from tests.denoise.helpers import untrained_bundle


def test_cbox_real_adaptive_render_spends_exactly_n_times_s(tmp_path, monkeypatch):
    maps: list[np.ndarray] = []
    real = spp_map_render.render_spp_map

    def recording(scene, spp_map, seed, sensor=None):
        maps.append(np.array(spp_map))
        return real(scene, spp_map, seed, sensor=sensor)

    monkeypatch.setattr(spp_map_render, "render_spp_map", recording)
    f = untrained_bundle(tmp_path, "f", "+experiment=F", "capacity=cpu")
    out = tmp_path / "out"
    scene = VENDORED_DIR / "cbox" / "scene.xml"
    report = run(["--scene", str(scene), "-o", str(out), "--checkpoint", str(f), "--width", "32",
                  "--height", "32", "--frames", "2", "--reference-spp", "64", "--reference-db", "0",
                  "--no-progress"])
    n, s = 32 * 32, 4
    assert len(maps) == 2  # one real adaptive render per frame, none simulated in the real model
    for row, m in zip(report["frames"], maps, strict=True):
        assert int(m.sum()) == n * (s - 1)  # what Mitsuba was asked to trace
        assert row["samples"] == n + int(m.sum()) == n * s
        assert np.isfinite(row["psnr_output"]) and np.isfinite(row["psnr_simulated"])
        assert row["psnr_output_minus_simulated"] == row["psnr_output"] - row["psnr_simulated"]
        stored = read_exr(out / f"cbox_{row['frame']:04d}_sampling_map.exr")[..., 0]
        assert np.array_equal(stored, m)  # the map written is the map rendered
    img = read_exr(out / "cbox_0000.exr")
    assert img.shape == (32, 32, 3) and np.isfinite(img).all()


def colour_renders(monkeypatch) -> list[int]:
    """Record the spp of every colour render of :class:`SceneRenderer` (the adaptive map is not one)."""
    spps: list[int] = []
    real = SceneRenderer.color

    def recording(self, spp, seed):
        spps.append(spp)
        return real(self, spp, seed)

    monkeypatch.setattr(SceneRenderer, "color", recording)
    return spps


def test_f_renders_only_what_it_reads(tmp_path, monkeypatch):
    """Without scores, F renders c_1 and its map's counts per frame: no uniform c_s it would not read."""
    spps = colour_renders(monkeypatch)
    f = untrained_bundle(tmp_path, "f", "+experiment=F", "capacity=cpu")
    report = run(["--scene", str(VENDORED_DIR / "cbox" / "scene.xml"), "-o", str(tmp_path / "out"),
                  "--checkpoint", str(f), "--width", "32", "--height", "32", "--frames", "2",
                  "--no-progress"])
    assert spps == [1, 1]  # c_1 of each frame, nothing else
    for row in report["frames"]:
        assert row["samples"] == row["budget_samples"] == 32 * 32 * 4
        assert row["extra_samples"] == 0 and row["score_samples"] == 0


def test_ntasad_reads_a_uniform_render_on_its_first_frame_only(tmp_path, monkeypatch):
    spps = colour_renders(monkeypatch)
    nt = untrained_bundle(tmp_path, "nt", "+experiment=ntasad", "capacity=cpu")
    report = run(["--scene", str(VENDORED_DIR / "cbox" / "scene.xml"), "-o", str(tmp_path / "out"),
                  "--checkpoint", str(nt), "--width", "32", "--height", "32", "--frames", "2",
                  "--no-progress"])
    n, s = 32 * 32, 4
    assert spps == [1, s, 1]  # frame 0: c_1 and its first-frame stand-in c_s; frame 1: c_1
    assert [row["extra_samples"] for row in report["frames"]] == [n * s, 0]
    assert all(row["samples"] == n * s for row in report["frames"])


@pytest.mark.slow
def test_scores_of_two_methods_share_exposure_uniform_input_and_reference(tmp_path, capsys):
    """A uniform method and F scored on one scene: the same exposure, the same uniform input's score, F's
    adaptive input as its own column; the reference is written beside the outputs and raised to its target."""
    scene = str(VENDORED_DIR / "cbox" / "scene.xml")
    common = ["--scene", scene, "--width", "32", "--height", "32", "--reference-spp", "4",
              "--reference-db", "30", "--reference-max-spp", "64", "--no-progress"]
    f = untrained_bundle(tmp_path, "f", "+experiment=F", "capacity=cpu")
    unet = untrained_bundle(tmp_path, "unet", "+experiment=unet", "capacity=cpu")
    rf = run([*common, "-o", str(tmp_path / "f"), "--checkpoint", str(f)])
    printed_f = capsys.readouterr().out
    ru = run([*common, "-o", str(tmp_path / "u"), "--checkpoint", str(unet)])
    printed_u = capsys.readouterr().out
    assert rf["score_exposure"] == ru["score_exposure"]
    assert rf["score_exposure_source"] == "frame 0's reference"
    assert rf["exposure_source"] == ru["exposure_source"] == "frame 0's input"  # each network's own input
    a, b = rf["frames"][0], ru["frames"][0]
    assert a["psnr_uniform"] == b["psnr_uniform"] and a["ssim_uniform"] == b["ssim_uniform"]
    assert "psnr_adaptive" in a and "psnr_adaptive" not in b
    assert "adaptive input" in printed_f and "adaptive input" not in printed_u
    assert "uniform input" in printed_f and "uniform input" in printed_u and "reference: " in printed_f
    ref = rf["reference"]
    assert ref["pilot_spp"] == 4 and ref["pilot_db"] < 30 and 4 < ref["spp"] <= 64  # raised toward 30 dB
    assert a["reference_spp"] == ref["spp"] and a["reference_psnr_estimate"] > ref["pilot_db"]
    pilot_and_ref = 4 + ref["spp"]  # frame 0: the pilot, then the reference at the raised spp
    assert a["score_samples"] == 32 * 32 * (pilot_and_ref + 4 + 1 + 2 + 4 + 8 + 16 + 32)  # c_s, the stack
    assert b["score_samples"] == 32 * 32 * pilot_and_ref  # the uniform method's input is its own c_s
    saved = [read_exr(tmp_path / d / "cbox_0000_reference.exr") for d in ("f", "u")]
    assert np.allclose(saved[0], saved[1], rtol=1e-6, atol=0) and saved[0].shape == (32, 32, 3)
    fixed = run([*common, "-o", str(tmp_path / "x"), "--checkpoint", str(unet), "--exposure", "2.5"])
    assert fixed["exposure"] == fixed["score_exposure"] == 2.5 and fixed["exposure_source"] == "--exposure"


#: A scene as Bitterli's Mitsuba 0.5 files are written: version 0.5.0, camelCase names, no <default>s.
OLD_FORMAT = """<?xml version="1.0" encoding="utf-8"?>
<scene version="0.5.0">
  <integrator type="path"><integer name="maxDepth" value="6"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="45"/>
    <transform name="toWorld"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="16"/></sampler>
    <film type="hdrfilm"><integer name="width" value="640"/><integer name="height" value="480"/></film>
  </sensor>
  <shape type="sphere"><float name="radius" value="1"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.5, 0.4"/></bsdf></shape>
  <shape type="rectangle">
    <transform name="toWorld"><scale value="4"/><translate z="-1.5"/></transform>
    <bsdf type="diffuse"/></shape>
  <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
</scene>
"""


def test_an_old_format_scene_without_defaults_renders_with_a_uniform_method(tmp_path):
    """Mitsuba 3 upgrades the 0.5 names itself; the film size comes from --width/--height, not the file."""
    scene = tmp_path / "mine" / "sphere.xml"
    scene.parent.mkdir()
    scene.write_text(OLD_FORMAT)
    unet = untrained_bundle(tmp_path, "unet", "+experiment=unet", "capacity=cpu")
    report = run(["--scene", str(scene), "-o", str(tmp_path / "out"), "--checkpoint", str(unet),
                  "--width", "32", "--height", "24", "--no-progress"])
    assert report["frames"][0]["samples"] == 32 * 24 * 4  # the uniform render c_s at the budget
    assert read_exr(tmp_path / "out" / "sphere_0000.exr").shape == (24, 32, 3)


def test_the_film_size_defaults_to_the_scenes_own(tmp_path):
    scene = tmp_path / "mine" / "sphere.xml"
    scene.parent.mkdir()
    scene.write_text(OLD_FORMAT.replace('"640"', '"40"').replace('"480"', '"30"'))
    unet = untrained_bundle(tmp_path, "unet", "+experiment=unet", "capacity=cpu")
    report = run(["--scene", str(scene), "-o", str(tmp_path / "out"), "--checkpoint", str(unet),
                  "--no-progress"])
    assert report["size"] == [30, 40] and read_exr(tmp_path / "out" / "sphere_0000.exr").shape == (30, 40, 3)


def test_bad_reference_settings_are_refused_before_rendering(tmp_path, capsys, monkeypatch):
    spps = colour_renders(monkeypatch)
    unet = untrained_bundle(tmp_path, "unet", "+experiment=unet", "capacity=cpu")
    base = ["--scene", str(VENDORED_DIR / "cbox" / "scene.xml"), "-o", str(tmp_path / "out"), "--checkpoint",
            str(unet), "--width", "32", "--height", "32", "--no-progress"]
    for extra, named in ((["--reference-spp", "3"], "--reference-spp=3"),
                         (["--reference-spp", "64", "--reference-max-spp", "32"], "--reference-max-spp=32"),
                         (["--exposure", "-1"], "argument --exposure: -1 is not a finite number above 0")):
        with pytest.raises(SystemExit) as stop:
            run([*base, *extra])
        assert stop.value.code == 2 and named in capsys.readouterr().err
    assert spps == [] and not (tmp_path / "out" / "cbox_0000.exr").exists()

"""Input (b): the paper's pipeline on a real renderer (docs/denoise.md, "Scenes: the real loop"). Cornell
box at 32x32: ``c_1``, ``F_s``, the predicted counts rendered by Mitsuba, the second stage; exactly ``N * s``
colour samples per frame."""

from __future__ import annotations

import numpy as np

import mcd.data.spp_map_render as spp_map_render
from mcd.data.exr import read_exr
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
    f = untrained_bundle(tmp_path, "f", "+experiment=F", "model=cpu")
    out = tmp_path / "out"
    scene = VENDORED_DIR / "cbox" / "scene.xml"
    report = run(["--scene", str(scene), "-o", str(out), "--checkpoint", str(f), "--width", "32",
                  "--height", "32", "--frames", "2", "--reference-spp", "64", "--no-progress"])
    n, s = 32 * 32, 4
    assert len(maps) == 2  # one real adaptive render per frame, none simulated in the real model
    for row, m in zip(report["frames"], maps, strict=True):
        assert int(m.sum()) == n * (s - 1)  # what Mitsuba was asked to trace
        assert row["samples"] == n + int(m.sum()) == n * s
        assert np.isfinite(row["psnr_real"]) and np.isfinite(row["psnr_simulated"])
        assert row["psnr_real_minus_simulated"] == row["psnr_real"] - row["psnr_simulated"]
        stored = read_exr(out / f"cbox_{row['frame']:04d}_sampling_map.exr")[..., 0]
        assert np.array_equal(stored, m)  # the map written is the map rendered
    img = read_exr(out / "cbox_0000.exr")
    assert img.shape == (32, 32, 3) and np.isfinite(img).all()


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
    unet = untrained_bundle(tmp_path, "unet", "+experiment=unet", "model=cpu")
    report = run(["--scene", str(scene), "-o", str(tmp_path / "out"), "--checkpoint", str(unet),
                  "--width", "32", "--height", "24", "--no-progress"])
    assert report["frames"][0]["samples"] == 32 * 24 * 4  # the uniform render c_s at the budget
    assert read_exr(tmp_path / "out" / "sphere_0000.exr").shape == (24, 32, 3)

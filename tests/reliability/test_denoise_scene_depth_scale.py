"""Campaign 10, part 2 (notes/reliability_campaigns.md): ``mcd-denoise --scene`` took the depth scale from
frame 0 alone, so a scene whose frame 0 hits nothing (the sky between two far walls, 500 units away) gave a
scale of 1, and frames 1-2 reached the network hundreds of times too far: their outputs differed by 4% and
13% of their mean from the same frames after a frame 0 with a hit (a small sphere off the camera's axis, so
that the camera path and frames 1-2 are the same), without a word (a silent wrong result; campaign 9 fixed
the same for frames on disk, where the same comparison gives 1% and 3%). The first frame with a hit gives
the scale now, as for frames. ``mcd-denoise`` renders and denoises for real (32x32, the bundled U-Net)."""

from __future__ import annotations

import numpy as np

from mcd.data.exr import read_exr
from mcd.denoise.cli import run

WALLS = """<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="4"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="8"/>
    <transform name="to_world"><lookat origin="0,0,0" target="0,0,-1" up="0,1,0"/></transform>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
  <shape type="rectangle">
    <transform name="to_world"><scale x="190" y="300" z="1"/><translate x="231" y="0" z="-500"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7,0.3,0.2"/></bsdf></shape>
  <shape type="rectangle">
    <transform name="to_world"><scale x="190" y="300" z="1"/><translate x="-231" y="0" z="-500"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.2,0.6,0.3"/></bsdf></shape>
  {extra}
</scene>
"""
#: In frame 0's view only (1.7 degrees off the axis: the forward ray that sets the camera path misses it).
SPHERE = ('<shape type="sphere"><point name="center" x="15" y="0" z="-500"/><float name="radius" value="3"/>'
          '<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>')


def test_a_scene_whose_frame_0_hits_nothing_takes_the_scale_of_the_first_frame_with_a_hit(tmp_path):
    for name, extra in (("sky", ""), ("hit", SPHERE)):
        (tmp_path / f"{name}.xml").write_text(WALLS.format(extra=extra))
        run(["--scene", str(tmp_path / f"{name}.xml"), "-o", str(tmp_path / name), "--checkpoint",
             "unet-cpu-small", "--frames", "3", "--exposure", "1", "--no-progress"])
    for f, most in ((1, 0.025), (2, 0.06)):  # 0.042 and 0.129 with the scale 1 of frame 0
        sky, hit = (read_exr(tmp_path / n / f"{n}_{f:04d}.exr") for n in ("sky", "hit"))
        assert np.abs(sky - hit).mean() / hit.mean() < most, f

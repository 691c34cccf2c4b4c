"""Campaign 11, part 2 (notes/reliability_campaigns.md; left by campaigns 6, 8 and 10): ``mcd-denoise
--scene`` took the network's exposure from frame 0's input alone, so a scene whose frame 0 renders black (a
point light on two far walls; the camera path pans onto them) got an exposure of 1, and frames 1-2 reached the
network about 39 times too dark: their outputs came out 26% and 27% of their mean off the same frames denoised
at an exposure near their own (``--exposure 38``), exit 0, without a word (a silent wrong result; campaign 6
fixed the same for frames on disk). The first frame whose input is not black gives the exposure now, as for
frames; the frames before it see the same (black) input at any exposure. ``mcd-denoise`` renders and denoises
for real (32x32, the bundled U-Net)."""

from __future__ import annotations

import numpy as np

from mcd.data.exr import read_exr
from mcd.denoise.cli import run
from tests.reliability.test_denoise_scene_depth_scale import WALLS

LIGHT = ('<emitter type="point"><point name="position" x="0" y="0" z="-400"/>'
         '<rgb name="intensity" value="5000"/></emitter>')
SKY = '<emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>'


def test_a_scene_whose_frame_0_is_black_takes_the_exposure_of_its_first_lit_frame(tmp_path):
    scene = tmp_path / "dark.xml"
    scene.write_text(WALLS.replace(SKY, LIGHT).format(extra=""))
    reports = {}
    for name, extra in (("auto", []), ("given", ["--exposure", "38"])):
        reports[name] = run(["--scene", str(scene), "-o", str(tmp_path / name), "--checkpoint",
                             "unet-cpu-small", "--frames", "3", "--no-progress", *extra])
    assert read_exr(tmp_path / "auto" / "dark_0000.exr").max() == 0  # frame 0 is black
    assert reports["auto"]["exposure_source"] == "frame 1's input", reports["auto"]["exposure_source"]
    for f in (1, 2):  # 0.26 and 0.27 with the exposure 1 of the black frame 0
        auto, given = (read_exr(tmp_path / n / f"dark_{f:04d}.exr") for n in ("auto", "given"))
        assert np.abs(auto - given).mean() / given.mean() < 0.03, f


def test_the_scores_of_a_scene_whose_frame_0_is_black_take_the_exposure_of_its_first_lit_reference(tmp_path):
    """With ``--reference-spp`` the scores' exposure and the reference's pilot came from frame 0's reference,
    black: exposure 1, and frames 1-2 were scored far too dark (output 40.07 dB for frame 1, 33.68 dB at
    ``--exposure 38``). The first lit frame's pilot sets both now
    (:class:`mcd.denoise.reference.ReferencePlan`)."""
    scene = tmp_path / "dark.xml"
    scene.write_text(WALLS.replace(SKY, LIGHT).format(extra=""))
    reports = {}
    for name, extra in (("auto", []), ("given", ["--exposure", "38"])):
        reports[name] = run(["--scene", str(scene), "-o", str(tmp_path / name), "--checkpoint",
                             "unet-cpu-small", "--frames", "3", "--reference-spp", "16", "--no-progress",
                             *extra])
    auto, given = reports["auto"], reports["given"]
    assert auto["score_exposure_source"] == "frame 1's reference", auto["score_exposure_source"]
    assert abs(auto["score_exposure"] / 38 - 1) < 0.1, auto["score_exposure"]
    for f in (1, 2):  # 6.4 dB and 5.8 dB above the scores at --exposure 38 with the exposure 1 of frame 0
        a, g = auto["frames"][f], given["frames"][f]
        assert abs(a["psnr_output"] - g["psnr_output"]) < 0.5, (f, a["psnr_output"], g["psnr_output"])
        assert abs(a["psnr_uniform"] - g["psnr_uniform"]) < 0.5, (f, a["psnr_uniform"], g["psnr_uniform"])

"""Campaign 9, part 2 (notes/reliability_campaigns.md): ``mcd-denoise`` on a sequence whose frame 0 hits
nothing (its depth layer all 0: the sky) and whose depths are in centimetres. The depth scale came from frame
0 alone, so it was 1 and frames 1-2 reached the network hundreds of times too far: their outputs differed from
the same frames with a frame 0 that hits something by 29% of their mean (a silent wrong result; campaign 6
fixed the same for the exposure). Now the first frame with a hit gives the scale. ``mcd-denoise`` runs for
real on the bundled U-Net."""

from __future__ import annotations

import numpy as np
import pytest

from mcd.data.exr import read_exr
from mcd.denoise.cli import run
from mcd.denoise.frames import LAYERS, read_frame, write_layers
from tests.reliability.denoise_helpers import write_frames


@pytest.mark.slow
def test_a_frame_0_without_depth_takes_the_scale_of_the_first_frame_with_a_hit(tmp_path):
    frames = write_frames(tmp_path / "raw", n=3, size=(32, 32))
    for name, blank in (("hit", False), ("sky", True)):
        for i, p in enumerate(frames):
            fr = read_frame(p, set(LAYERS))
            depth = np.zeros_like(fr["depth"]) if blank and i == 0 else fr["depth"] * 500.0
            write_layers(tmp_path / name / p.name, fr["colour"], {"albedo": fr["albedo"],
                                                                 "normal": fr["normal"],
                                                               "depth": depth})
        run([str(tmp_path / name), "-o", str(tmp_path / f"out_{name}"), "--checkpoint", "unet-cpu-small",
             "--no-progress"])
    for stem in ("f0001", "f0002"):
        hit, sky = (read_exr(tmp_path / f"out_{n}" / f"{stem}.exr") for n in ("hit", "sky"))
        assert np.abs(hit - sky).mean() / hit.mean() < 0.05  # 0.29 with the scale 1 of frame 0

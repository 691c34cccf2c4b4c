"""Campaign 11, part 2 (notes/reliability_campaigns.md): ``mcd-denoise`` into an ``-o`` that a run of other
inputs finished replaced its ``denoise.json`` and left its outputs beside the new ones without a record, exit
0: frames ``g0000..g0001`` into the ``-o`` of ``f0000..f0002`` (its scores and checksums lost), a ``--scene``
of another scene into a finished scene's ``-o``, and (left low by campaigns 6 and 10) a rerun with fewer
frames. The record of the same kind was accepted as the run's own (campaign 10's ``check_kind`` compared the
kinds only). Such an ``-o`` is refused now before any work, naming the earlier outputs
(``mcd.denoise.resume.check_earlier_outputs``), and every file keeps its bytes; a rerun over the same frames
resumes or is written again as before. A scene record names its scene file and its outputs. Real runs (the
bundled U-Net, frames of 16x24, the Cornell box at 16x16)."""

from __future__ import annotations

import json

from mcd.data.scenes import VENDORED_DIR
from mcd.denoise.cli import run
from tests.reliability.denoise_helpers import refused, snapshot, write_frames
from tests.reliability.test_denoise_scene_depth_scale import WALLS

UNET = ["--checkpoint", "unet-cpu-small", "--no-progress"]


def test_other_frames_or_fewer_into_a_finished_output_are_refused_and_it_is_kept(tmp_path, capsys):
    write_frames(tmp_path / "f", n=3)
    write_frames(tmp_path / "g", n=2, seed=5, prefix="g")
    out = tmp_path / "out"
    run([str(tmp_path / "f"), "-o", str(out), *UNET])
    before = snapshot(out)
    err = refused(capsys, str(tmp_path / "g"), "-o", str(out), *UNET)
    assert "f0000.exr" in err and "outputs of an earlier run" in err and "give another -o" in err, err
    fewer = [str(tmp_path / "f" / f"f000{i}.exr") for i in (0, 1)]
    err = refused(capsys, *fewer, "-o", str(out), *UNET)
    assert "f0002.exr, f0002.png" in err, err
    assert snapshot(out) == before
    # the same frames again (other settings: every frame again; the same: resumed)
    run([str(tmp_path / "f"), "-o", str(out), "--exposure", "2", *UNET])
    assert run([str(tmp_path / "f"), "-o", str(out), "--exposure", "2", *UNET])["resumed"] == [
        "f0000", "f0001", "f0002"]


def test_another_scene_or_fewer_frames_into_a_finished_scene_output_are_refused(tmp_path, capsys):
    cbox = VENDORED_DIR / "cbox" / "scene.xml"
    other = tmp_path / "walls.xml"
    other.write_text(WALLS.format(extra=""))
    size = ["--width", "16", "--height", "16"]
    out = tmp_path / "out"
    report = run(["--scene", str(cbox), "-o", str(out), "--frames", "2", *size, *UNET])
    assert report["scene"] == str(cbox)
    assert report["outputs"] == ["cbox_0000.exr", "cbox_0000.png", "cbox_0001.exr", "cbox_0001.png"]
    before = snapshot(out)
    err = refused(capsys, "--scene", str(other), "-o", str(out), *size, *UNET)
    assert "cbox_0000.exr" in err and "outputs of an earlier run" in err, err
    err = refused(capsys, "--scene", str(cbox), "-o", str(out), "--frames", "1", *size, *UNET)
    assert "cbox_0001.exr, cbox_0001.png" in err, err
    assert snapshot(out) == before
    run(["--scene", str(cbox), "-o", str(out), "--frames", "2", *size, *UNET])  # the same: written again
    assert len(json.loads((out / "denoise.json").read_text())["outputs"]) == 4

"""Campaign 10, part 2 (notes/reliability_campaigns.md): ``mcd-denoise`` on frames into an ``-o`` that a
``--scene`` run finished replaced its ``denoise.json`` (the scene run's samples, exposures and scores) and
left the scene's outputs there without a record, exit 0; campaign 8 left the mirror case (a scene run into a
frames run's ``-o``). Both are refused now before any work (``mcd.denoise.resume.check_kind``), the earlier
record kept; a rerun of the same kind goes on as before. ``mcd-denoise`` runs for real (the Cornell box at
16x16, the bundled U-Net)."""

from __future__ import annotations

import pytest

from mcd.data.scenes import VENDORED_DIR
from mcd.denoise.cli import run
from tests.reliability.denoise_helpers import refused, write_frames

SCENE = ["--scene", str(VENDORED_DIR / "cbox" / "scene.xml"), "--width", "16", "--height", "16"]


@pytest.mark.slow
def test_a_run_of_the_other_kind_is_refused_and_the_earlier_record_kept(tmp_path, capsys):
    write_frames(tmp_path / "frames", n=2, size=(16, 16))
    scene_out, frames_out = tmp_path / "scene_out", tmp_path / "frames_out"
    run([*SCENE, "-o", str(scene_out), "--checkpoint", "unet-cpu-small", "--no-progress"])
    run([str(tmp_path / "frames"), "-o", str(frames_out), "--checkpoint", "unet-cpu-small", "--no-progress"])
    records = {o: (o / "denoise.json").read_bytes() for o in (scene_out, frames_out)}

    err = refused(capsys, str(tmp_path / "frames"), "-o", str(scene_out), "--checkpoint", "unet-cpu-small")
    assert "the record of an mcd-denoise --scene run" in err and "give another -o" in err, err
    assert not (scene_out / "f0000.exr").exists()
    err = refused(capsys, *SCENE, "-o", str(frames_out), "--checkpoint", "unet-cpu-small")
    assert "the record of an mcd-denoise run on frames" in err, err
    assert not list(frames_out.glob("cbox_*"))
    assert {o: (o / "denoise.json").read_bytes() for o in records} == records

    # the same kind again: a scene is written again, frames resume
    run([*SCENE, "-o", str(scene_out), "--checkpoint", "unet-cpu-small", "--no-progress"])
    report = run([str(tmp_path / "frames"), "-o", str(frames_out), "--checkpoint", "unet-cpu-small",
                  "--no-progress"])
    assert report["resumed"] == ["f0000", "f0001"]

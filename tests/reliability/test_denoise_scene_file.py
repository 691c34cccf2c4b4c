"""``mcd-denoise --scene`` names a missing or unreadable scene file before it claims ``-o``
(``mcd.denoise.cli._scene``; docs/reliability.md, "Campaign fixes"): the file was first read when the scene
was loaded, after ``-o`` had been made and a first ``denoise.json`` (``{"complete": false}``) written into
it."""

from __future__ import annotations

from tests.reliability.denoise_helpers import refused


def test_a_missing_or_camera_less_scene_is_named_and_leaves_no_output_folder(capsys, tmp_path):
    out = tmp_path / "out"
    base = ["-o", str(out), "--checkpoint", "unet-cpu-small", "--width", "16", "--height", "16",
            "--frames", "1"]
    err = refused(capsys, "--scene", str(tmp_path / "nope" / "scene.xml"), *base)
    assert "nope" in err and "not found" in err and "--scene" in err
    assert not out.exists()

    scene = tmp_path / "nocam.xml"
    scene.write_text('<scene version="3.0.0"><shape type="sphere"/></scene>\n')
    err = refused(capsys, "--scene", str(scene), *base)
    assert str(scene) in err and "<sensor>" in err
    assert not out.exists()

    out.mkdir()  # a folder of the user's: nothing joins it
    (out / "mine.txt").write_text("x")
    refused(capsys, "--scene", str(tmp_path / "nope.xml"), *base)
    assert sorted(p.name for p in out.iterdir()) == ["mine.txt"]

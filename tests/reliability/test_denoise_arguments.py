"""``mcd-denoise`` refuses bad arguments and checkpoints before any work, naming the flag or file and what is
valid (docs/reliability.md, "Denoising your frames"; mcd/denoise/arguments.py, work.py, weights.py)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from mcd.denoise import render_frames
from mcd.denoise.cli import parser
from tests.denoise.helpers import REPO, untrained_bundle
from tests.reliability.denoise_helpers import refused, write_frames

CBOX = str(REPO / "scenes" / "cbox" / "scene.xml")


@pytest.fixture(scope="module")
def unet(tmp_path_factory) -> Path:
    return untrained_bundle(tmp_path_factory.mktemp("bundles"),
                            "unet-args", "+experiment=unet", "capacity=cpu")


def parse_error(capsys, parse, *argv: str) -> str:
    with pytest.raises(SystemExit) as exc:
        parse(list(argv))
    assert exc.value.code == 2
    return capsys.readouterr().err


@pytest.mark.parametrize(("flag", "value", "says"), [
    ("--gbuffer-spp", "0", "0 is not an integer from 1 to 65536"),
    ("--width", "0", "0 is not an integer from 8 to 16384"),
    ("--width", "100000", "100000 is not an integer from 8 to 16384"),
    ("--height", "7.5", "'7.5' is not an integer"),
    ("--reference-spp", "-3", "-3 is not an integer from 0 to 1048576"),
    ("--max-memory-mb", "-5", "-5 is not a finite number above 0"),
    ("--max-memory-mb", "nan", "nan is not a finite number above 0"),
    ("--overlap", "-40", "-40 is not an integer from 0 to 1024"),
    ("--frames", "0", "0 is not an integer from 1 to 1000000"),
])
def test_a_bad_numeric_argument_names_its_flag_and_range(tmp_path, capsys, flag, value, says):
    err = parse_error(capsys, parser().parse_args, "--scene", CBOX, "-o", str(tmp_path), flag, value)
    assert f"argument {flag}: {says}" in err
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize(("flag", "value", "says"), [
    ("--spp", "0", "0 is not an integer from 1 to 65536"),
    ("--frames", "-1", "-1 is not an integer from 1 to 100000"),
    ("--pan-deg", "inf", "inf is not a finite number from -360 to 360"),
])
def test_render_frames_refuses_bad_numbers_naming_the_flag(tmp_path, capsys, flag, value, says):
    err = parse_error(capsys, render_frames.main, CBOX, str(tmp_path / "f"), flag, value)
    assert f"argument {flag}: {says}" in err
    assert not (tmp_path / "f").exists()


def test_large_work_is_refused_unless_allowed(tmp_path, capsys, monkeypatch):
    err = refused(capsys, "--scene", CBOX, "-o", str(tmp_path / "o1"), "--experiment", "noisy",
                  "--reference-spp", "1000000", "--reference-max-spp", "1048576")  # its own film size
    assert "samples to trace: 6.55e+10, above the limit of 4.29e+09" in err and "--allow-large" in err
    assert "at 256x256" in err
    err = refused(capsys, "--scene", CBOX, "-o", str(tmp_path / "o2"), "--experiment", "noisy", "--frames",
                  "100000", "--width", "256", "--height", "256")
    assert "100000 frame(s)" in err and "--allow-large" in err
    write_frames(tmp_path / "in", n=3)
    from mcd.denoise import work

    monkeypatch.setattr(work, "MAX_PIXELS", 2 * 16 * 24)                     # two frames' worth
    err = refused(capsys, str(tmp_path / "in"), "-o", str(tmp_path / "o"), "--experiment", "noisy")
    assert "3 frames of 24x16: pixels to denoise: 1.15e+03, above the limit of 768" in err
    assert not (tmp_path / "o").exists()
    from mcd.denoise.cli import run

    report = run([str(tmp_path / "in"), "-o", str(tmp_path / "o"), "--experiment", "noisy", "--allow-large",
                  "--no-progress"])
    assert report["frames"] == 3


def test_a_file_that_is_no_checkpoint_is_named(tmp_path, capsys):
    junk = tmp_path / "passwd"
    junk.write_text("root:x:0:0:root:/root:/bin/bash\n")
    err = refused(capsys, "--scene", CBOX, "-o", str(tmp_path / "o"), "--checkpoint", str(junk))
    assert f"--checkpoint={junk}: not a readable checkpoint" in err


@pytest.mark.parametrize("damage", ["no_config", "malformed", "absurd_widths"])
def test_a_damaged_bundle_json_is_named_before_anything_is_built(tmp_path, capsys, unet, damage):
    pt = tmp_path / "b.pt"
    shutil.copy(unet, pt)
    meta = json.loads(unet.with_suffix(".json").read_text())
    if damage == "no_config":
        del meta["config"]
        text = json.dumps(meta)
    elif damage == "malformed":
        text = json.dumps(meta)[:-40]
    else:
        # within the width rule (mcd.core.config_rules: at most 4096, which a width of 200000 breaks, named by
        # its key since campaign 11), yet a model of 3.2e9 parameters
        meta["config"]["capacity"]["two_stage"]["denoiser"]["widths"] = [4096] * 5
        text = json.dumps(meta)
    pt.with_suffix(".json").write_text(text)
    err = refused(capsys, "--scene", CBOX, "-o", str(tmp_path / "o"), "--checkpoint", str(pt))
    assert {"no_config": f"{pt.with_suffix('.json')}: its 'config' lacks experiment, method, capacity",
            "malformed": f"{pt.with_suffix('.json')}: not a readable bundle JSON",
            "absurd_widths": "above the limit of 2.68e+08"}[damage] in err


def test_an_unknown_experiment_lists_the_valid_ones(tmp_path, capsys):
    err = refused(capsys, "--scene", CBOX, "-o", str(tmp_path / "o"), "--experiment", "bogus")
    assert "--experiment=bogus: no such experiment" in err and "noisy" in err and "unet" in err


@pytest.mark.parametrize("kind", ["folder", "device", "fifo"])
def test_a_scene_that_is_no_file_is_named_as_what_it_is(tmp_path, capsys, kind):
    if kind == "folder":
        scene, says = str(REPO / "scenes" / "cbox"), "is a folder; give the Mitsuba 3 scene's .xml file in it"
    elif kind == "device":
        scene, says = "/dev/zero", "is a device"
    else:
        scene, says = str(tmp_path / "pipe"), "is a FIFO"
        os.mkfifo(scene)
    err = parse_error(capsys, parser().parse_args, "--scene", scene, "-o", str(tmp_path / "o"))
    assert f"argument --scene: {scene} {says}" in err


def test_help_shows_every_options_default(capsys):
    with pytest.raises(SystemExit):
        parser().parse_args(["--help"])
    out = " ".join(capsys.readouterr().out.split("options:", 1)[1].split())
    assert "(default: None)" not in out and "(default: False)" not in out
    for flag, default in [("--frames", "1"), ("--gbuffer-spp", "16"), ("--max-memory-mb", "4096"),
                          ("--overlap", "32"), ("--precision", "fp32"), ("--device", "cpu")]:
        assert f"(default: {default})" in out.split(flag, 1)[1].split(" --", 1)[0], flag

"""Campaign 12, part 2 (left by campaign 11, part 2; notes/reliability_campaigns.md): a ``--scene`` rerun
into its own ``-o`` without ``--reference-spp``, after one with it, left the first run's ``*_reference`` files
beside the new outputs, and the new record's ``outputs`` listed them as its own (every name a frame may have
that was a file). The record lists what this run wrote now, and a warning names the earlier files left
beside them (nothing is deleted). A real run: the bundled U-Net on the Cornell box at 16x16."""

from __future__ import annotations

import json
import logging

from mcd.data.scenes import VENDORED_DIR
from mcd.denoise.cli import run

UNET = ["--checkpoint", "unet-cpu-small", "--no-progress", "--width", "16", "--height", "16"]


def test_a_rerun_without_a_reference_lists_only_its_own_outputs_and_names_the_earlier_ones(tmp_path, caplog):
    cbox = str(VENDORED_DIR / "cbox" / "scene.xml")
    out = tmp_path / "out"
    first = run(["--scene", cbox, "-o", str(out), "--reference-spp", "4", "--reference-db", "0", *UNET])
    assert "cbox_0000_reference.exr" in first["outputs"]
    with caplog.at_level(logging.WARNING, logger="mcd.denoise.scene"):
        second = run(["--scene", cbox, "-o", str(out), *UNET])
    assert second["outputs"] == ["cbox_0000.exr", "cbox_0000.png"]
    assert json.loads((out / "denoise.json").read_text())["outputs"] == second["outputs"]
    assert (out / "cbox_0000_reference.exr").is_file()   # kept, and named
    assert "cbox_0000_reference.exr, cbox_0000_reference.png: from an earlier run" in caplog.text, caplog.text

"""Campaign 12, part 2 (notes/reliability_campaigns.md): file names that ``mcd-denoise`` reads from an
earlier ``denoise.json`` are taken only where they name a file in ``-o`` itself. A record whose ``checksums``
listed ``../secret.txt`` for a frame (a crafted or hand-edited record) made the rerun refuse ``-o``, naming
that file outside it as "outputs of an earlier run" and advising to delete it. Such names are not taken now
(``mcd.denoise.resume.recorded_outputs``, and a frame whose recorded files are not its own is not kept):
the rerun denoises the frame again, and the file outside keeps its bytes. Real runs (the bundled U-Net)."""

from __future__ import annotations

import hashlib
import json

from mcd.denoise.cli import run
from tests.reliability.denoise_helpers import write_frames

UNET = ["--checkpoint", "unet-cpu-small", "--no-progress"]


def test_a_recorded_name_outside_the_output_folder_is_not_taken(tmp_path, capsys):
    frames = tmp_path / "in"
    write_frames(frames, n=2)
    out = tmp_path / "out"
    run([str(frames), "-o", str(out), *UNET])
    secret = tmp_path / "secret.txt"
    secret.write_text("the user's")
    record = json.loads((out / "denoise.json").read_text())
    record["checksums"]["f0001"] = {"../secret.txt": hashlib.sha256(secret.read_bytes()).hexdigest()}
    (out / "denoise.json").write_text(json.dumps(record))
    for name in ("f0001.exr", "f0001.png"):
        (out / name).unlink()
    report = run([str(frames), "-o", str(out), *UNET])
    assert json.loads((out / "denoise.json").read_text())["complete"]
    assert (out / "f0001.exr").is_file() and (out / "f0001.png").is_file()
    assert report["resumed"] == ["f0000"]
    assert secret.read_text() == "the user's"
    assert "secret" not in capsys.readouterr().err

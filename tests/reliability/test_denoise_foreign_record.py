"""Campaign 9, part 2 (notes/reliability_campaigns.md): ``mcd-denoise -o`` into a folder that holds another
program's ``denoise.json``. Campaign 5's fix refused a folder whose files are named like outputs only where no
``denoise.json`` is there, and took any ``denoise.json`` for ``mcd-denoise``'s own: in frames mode a JSON
object without its fields (a user's own settings file) was replaced, and a user's ``f0000.png`` beside it
overwritten; in scene mode any ``denoise.json``, JSON or not, was, and the scene's outputs were written over
the user's files. Now a ``denoise.json`` that holds none of ``mcd.denoise.resume.OWN_FIELDS`` (or is not
JSON) is refused in both modes before any work, and every file stays; a folder ``mcd-denoise`` wrote still
resumes (frames) or is written again (scene). ``mcd-denoise`` runs for real (scene mode renders the vendored
Cornell box at 16x16)."""

from __future__ import annotations

import json
import subprocess

import pytest

from tests.conftest import command_in_worker
from tests.denoise.helpers import REPO
from tests.reliability.denoise_helpers import snapshot, write_frames

SCENE = REPO / "scenes" / "cbox" / "scene.xml"


def _denoise(out, *given: str) -> subprocess.CompletedProcess:
    """``python -m mcd.denoise``, in this process (:func:`tests.conftest.command_in_worker`)."""
    argv = [*given, "-o", str(out), "--experiment", "noisy", "--no-progress"]
    return command_in_worker("mcd.denoise", argv, REPO, {"PYTHONPATH": str(REPO), "OMP_NUM_THREADS": "1"})


@pytest.mark.parametrize("mode", ["frames", "scene"])
@pytest.mark.slow
def test_another_programs_denoise_json_and_the_files_beside_it_are_kept(tmp_path, mode):
    write_frames(tmp_path / "in", n=2)
    given = [str(tmp_path / "in")] if mode == "frames" else ["--scene", str(SCENE), "--width", "16",
                                                              "--height", "16"]
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "denoise.json").write_text('{"model": "my-denoiser", "strength": 3}\n')
    (mine / ("f0000.png" if mode == "frames" else "cbox_0000.png")).write_bytes(b"my own picture")
    before = snapshot(mine)
    proc = _denoise(mine, *given)
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert "Traceback" not in proc.stderr, proc.stderr
    assert (f"mcd-denoise: error: {mine / 'denoise.json'}: not a record of mcd-denoise (a JSON object "
            "without its fields complete or out_dir: another program's file?)") in proc.stderr
    assert snapshot(mine) == before
    if mode == "scene":  # not JSON at all: refused too (it was replaced)
        (mine / "denoise.json").write_text("model: my-denoiser\n")
        before = snapshot(mine)
        proc = _denoise(mine, *given)
        assert proc.returncode == 2 and "not readable JSON" in proc.stderr, proc.stderr[-3000:]
        assert snapshot(mine) == before

    ours = tmp_path / "ours"  # a folder mcd-denoise wrote: resumed (frames) or written again (scene)
    assert _denoise(ours, *given).returncode == 0
    again = _denoise(ours, *given)
    assert again.returncode == 0, again.stderr[-3000:]
    record = json.loads((ours / "denoise.json").read_text())
    assert record["out_dir"] == str(ours)
    if mode == "frames":
        assert record["resumed"] == ["f0000", "f0001"]

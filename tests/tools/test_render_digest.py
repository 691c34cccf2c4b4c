"""A fixed seed reproduces a render bit for bit (docs/data.md, "Reproducible renders"), checked by the lab's
``tools/render_digest.py``.

Every vendored scene and the procedural room are rendered at 128x128 in two separate processes, the second
with one Dr.Jit thread, and their digests must match. Before the fix (scenes loaded with Mitsuba's default
``optimize=True``), staircase2 and the procedural room differed from process to process.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def digests(*args: str) -> dict[str, str]:
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    tool = REPO / "tools" / "render_digest.py"  # a lab tool, run as tools/README.md says
    proc = subprocess.run([sys.executable, str(tool), "--procedural", "--size", "128", "--spp", "2", "--seed",
                           "7", *args], cwd=REPO, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return json.loads(proc.stdout[proc.stdout.index("{"):])


@pytest.mark.slow
def test_every_vendored_scene_renders_bit_identically_in_two_processes():
    first, second = digests(), digests("--threads", "1")
    assert {"cbox", "cornell-box-picture", "staircase2", "procedural"} <= set(first)
    different = sorted(name for name in first if first[name] != second.get(name))
    assert not different, f"renders differ between two processes with the same seed: {different}"

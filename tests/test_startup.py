"""Every command starts fast (docs/architecture.md, "Start-up"): ``--help`` imports none of the heavy
libraries, and ``mcd-denoise`` imports only what its input needs (Mitsuba only for ``--scene``, Lightning
never). Each check runs the command in a fresh interpreter, as a user does.

The import checks are deterministic; the time check measures the child's CPU time (not wall time, which the
machine's load inflates) and fails only well above the goal of 1 s.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
#: Libraries that take seconds to import; none belongs on the path to ``--help``.
HEAVY = ("torch", "lightning", "mitsuba", "drjit", "pandas", "matplotlib", "skimage", "scipy")
#: The commands whose ``--help`` must be fast (``mcd-denoise`` is ``python -m mcd.denoise``).
COMMANDS = ("mcd.run", "mcd.render", "mcd.report", "mcd.bench", "mcd.denoise")
CPU_LIMIT_S = 3.0

#: Runs module ``argv[1]`` as ``python -m`` does with the rest of argv, then prints the top-level packages
#: imported (after a marker line, since the command writes to stdout too).
PROBE = """
import json, runpy, sys
mod, sys.argv = sys.argv[1], [sys.argv[1], *sys.argv[2:]]
code = 0
try:
    runpy.run_module(mod, run_name="__main__", alter_sys=True)
except SystemExit as stop:
    code = stop.code or 0
print("\\n@@modules@@", json.dumps({"code": code, "modules": sorted({m.split(".")[0] for m in sys.modules})}))
"""


def probe(*argv: str) -> tuple[int, set[str], str]:
    """``(exit code, top-level packages imported, output)`` of ``python -m argv...``, a fresh interpreter."""
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.run([sys.executable, "-c", PROBE, *argv], cwd=REPO, env=env, capture_output=True,
                          text=True, timeout=600)
    out, _, tail = proc.stdout.rpartition("\n@@modules@@ ")
    assert tail, proc.stderr[-3000:]
    found = json.loads(tail)
    return found["code"], set(found["modules"]), out


@pytest.mark.parametrize("module", COMMANDS)
def test_help_imports_no_heavy_library(module):
    code, modules, out = probe(module, "--help")
    assert code == 0 and ("usage" in out.lower() or "== Config ==" in out), out[-2000:]
    assert not modules & set(HEAVY), f"python -m {module} --help imports {sorted(modules & set(HEAVY))}"


@pytest.mark.parametrize("module", COMMANDS)
def test_help_takes_well_under_the_limit(module):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    proc = subprocess.run([sys.executable, "-m", module, "--help"], cwd=REPO, capture_output=True, text=True,
                          env={**os.environ, "PYTHONPATH": str(REPO)}, timeout=600)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert cpu < CPU_LIMIT_S, f"python -m {module} --help took {cpu:.2f} s of CPU (goal 1 s)"


def test_denoising_frames_imports_neither_mitsuba_nor_lightning(tmp_path):
    from tests.denoise.helpers import render_sequence

    render_sequence(tmp_path / "frames", frames=2)
    code, modules, out = probe("mcd.denoise", str(tmp_path / "frames"), "-o", str(tmp_path / "out"),
                               "--checkpoint", "unet-cpu-small", "--no-progress")
    assert code == 0 and (tmp_path / "out" / "cbox_0001.exr").is_file(), out[-2000:]
    assert "torch" in modules  # the probe sees what the command imported
    assert not modules & {"mitsuba", "drjit", "lightning", "pandas"}, sorted(modules)


def test_denoising_a_scene_imports_no_lightning(tmp_path):
    code, modules, out = probe("mcd.denoise", "--scene", str(REPO / "scenes" / "cbox" / "scene.xml"), "-o",
                               str(tmp_path / "out"), "--checkpoint", "unet-cpu-small", "--width", "32",
                               "--height", "32", "--no-progress")
    assert code == 0 and (tmp_path / "out" / "cbox_0000.exr").is_file(), out[-2000:]
    assert "mitsuba" in modules and not modules & {"lightning", "pandas"}, sorted(modules)

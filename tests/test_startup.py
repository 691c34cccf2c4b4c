"""Every command starts fast (docs/architecture.md, "Start-up"): ``--help`` imports none of the heavy
libraries, and ``mcd-denoise`` imports only what its input needs (Mitsuba only for ``--scene``, Lightning
never). Each check runs the command in a fresh interpreter, as a user does.

The checks are deterministic: how long ``--help`` takes is measured by ``tools/startup_bench.py``, not
by a test (a shared machine's load would fail it at random).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from tools.startup_bench import COMMANDS  # the commands whose --help must be fast

REPO = Path(__file__).resolve().parents[1]
#: Libraries that take seconds to import; none belongs on the path to ``--help``.
HEAVY = ("torch", "lightning", "mitsuba", "drjit", "pandas", "matplotlib", "skimage", "scipy")

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


def test_a_hydra_commands_help_lists_what_hydras_own_help_lists():
    """The fast ``--help`` of the Hydra commands (mcd.config.compose.app_help) reads the groups from the file
    system; they must be the ones Hydra itself finds, less Hydra's own groups and the private ``_name``
    files."""
    from hydra._internal.config_loader_impl import ConfigLoaderImpl
    from hydra._internal.utils import create_config_search_path
    from hydra.core.object_type import ObjectType

    from mcd.config.compose import CONF_DIR, config_groups

    loader = ConfigLoaderImpl(config_search_path=create_config_search_path(str(CONF_DIR)))

    def walk(parent: str = "") -> dict[str, list[str]]:
        found = {}
        for group in loader.list_groups(parent):
            name = f"{parent}/{group}" if parent else group
            options = loader.get_group_options(name, ObjectType.CONFIG)
            if options and not name.startswith("hydra"):
                found[name] = sorted(o for o in options if not o.startswith("_"))
            found.update(walk(name))
        return found

    assert config_groups() == dict(sorted(walk().items()))


def test_help_shows_the_config_its_overrides_compose():
    code, _, out = probe("mcd.run", "+experiment=C", "train.max_steps=7", "--help")
    assert code == 0 and out.startswith("usage: python -m mcd.run"), out[-2000:]
    groups = out.split("== Configuration groups ==", 1)[1].split("== Config ==", 1)[0]
    assert "experiment: A, B, C, D," in groups and "_sweep_dirs" not in groups
    config = out.split("== Config ==", 1)[1]
    assert "  PP: false\n" in config and "  max_steps: 7\n" in config  # row C and the override
    assert "--hydra-help" in out.splitlines()[-1]


def test_help_with_a_bad_override_names_it_and_exits_2():
    proc = subprocess.run([sys.executable, "-m", "mcd.run", "data=nope", "--help"], cwd=REPO, text=True,
                          capture_output=True, env={**os.environ, "PYTHONPATH": str(REPO)}, timeout=600)
    assert proc.returncode == 2 and proc.stderr.startswith("error: ") and "data/nope" in proc.stderr, \
        proc.stderr[-2000:]
    assert "Traceback" not in proc.stderr


@pytest.mark.slow
def test_denoising_frames_imports_neither_mitsuba_nor_lightning(tmp_path):
    from tests.denoise.helpers import render_sequence

    render_sequence(tmp_path / "frames", frames=2)
    code, modules, out = probe("mcd.denoise", str(tmp_path / "frames"), "-o", str(tmp_path / "out"),
                               "--checkpoint", "unet-cpu-small", "--no-progress")
    assert code == 0 and (tmp_path / "out" / "cbox_0001.exr").is_file(), out[-2000:]
    assert "torch" in modules  # the probe sees what the command imported
    assert not modules & {"mitsuba", "drjit", "lightning", "pandas"}, sorted(modules)


@pytest.mark.slow
def test_denoising_a_scene_imports_no_lightning(tmp_path):
    code, modules, out = probe("mcd.denoise", "--scene", str(REPO / "scenes" / "cbox" / "scene.xml"), "-o",
                               str(tmp_path / "out"), "--checkpoint", "unet-cpu-small", "--width", "32",
                               "--height", "32", "--no-progress")
    assert code == 0 and (tmp_path / "out" / "cbox_0000.exr").is_file(), out[-2000:]
    assert "mitsuba" in modules and not modules & {"lightning", "pandas"}, sorted(modules)

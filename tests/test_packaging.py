"""The wheel carries what an installed ``mcd`` reads at run time (docs/architecture.md,
"Layers"): the Hydra configs, the vendored scenes and the bundled checkpoints, so that ``mcd-denoise`` and
``python -m mcd.run`` work from any directory after ``pip install .``; and none of the lab (``tools/``,
tools/README.md)."""

from __future__ import annotations

import importlib.util
import os
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from omegaconf import OmegaConf

from mcd.config.methods import COMPONENTS
from mcd.core.paths import CONF_DIR, PACKAGE_DIR, VENDORED_SCENES_DIR
from mcd.models.switches import SWITCHES

REPO = Path(__file__).resolve().parents[1]
LAB = REPO / "tools"  # the investigation tools: not packaged (tools/README.md)


def _files(folder: Path) -> set[str]:
    return {p.relative_to(PACKAGE_DIR.parent).as_posix() for p in folder.rglob("*")
            if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".md"}


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel, built from a copy of the sources (so the checkout gets no build folder), the lab's
    ``tools/`` beside the package as in the checkout."""
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    for part, folder in (("mcd", PACKAGE_DIR), ("hydra_plugins", REPO / "hydra_plugins"), ("tools", LAB)):
        shutil.copytree(folder, src / part, ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(REPO / "pyproject.toml", src)
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(tmp / "dist"), str(src)], check=True, capture_output=True, timeout=300)
    (built,) = (tmp / "dist").glob("mcd-*.whl")
    return built


@pytest.mark.slow
def test_the_wheel_carries_conf_scenes_and_bundles(wheel):
    """The wheel's files against the package's data folders."""
    names = set(zipfile.ZipFile(wheel).namelist())
    wanted = (_files(CONF_DIR) | _files(VENDORED_SCENES_DIR) | _files(PACKAGE_DIR / "bundled")
              | _files(PACKAGE_DIR / "reporting" / "viewer_page"))
    assert "mcd/reporting/viewer_page/viewer.js" in wanted
    assert "mcd/conf/config.yaml" in wanted and "mcd/scenes/cbox/scene.xml" in wanted
    assert wanted - names == set(), "package data missing from the wheel: pyproject.toml [tool.setuptools]"
    assert {"mcd/run.py", "mcd/denoise/cli.py", "mcd/bench/__main__.py", "mcd/bench/speed.py",
            "mcd/complexity.py"} <= names
    # the planned sweeper's name for Hydra (conf/hydra/sweeper/planned.yaml), outside the mcd package
    assert "hydra_plugins/mcd_sweep_plan/planned_sweeper.py" in names


def test_no_lab_tool_is_in_the_wheel(wheel):
    """The lab sits beside the package in the checkout; the wheel carries neither its folder nor any of its
    files under another name (pyproject.toml's ``packages.find`` includes ``mcd`` and ``hydra_plugins``)."""
    names = zipfile.ZipFile(wheel).namelist()
    lab = {p.name for p in LAB.glob("*.py")} - {"__init__.py"}
    assert "stage_ring.py" in lab and "startup_bench.py" in lab
    assert [n for n in names if n.startswith("tools/") or Path(n).name in lab] == []


@pytest.mark.slow
def test_the_installed_package_runs_from_another_folder(wheel, tmp_path):
    """The wheel installed (not editable) into a folder of its own and run from a folder outside the checkout,
    with nothing of the checkout on the path: ``python -m mcd.run --help`` lists the groups (``paths``) and
    rows A-M (registered from the component table, mcd/config/compose.py); ``+experiment=C`` composes to row
    C; a ``paths.scenes_dir`` that names no folder is refused naming the key; ``mcd-denoise --experiment
    oidn`` denoises frames rendered by the installed ``mcd.denoise.render_frames`` from its vendored Cornell
    box."""
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "-q",
                    "--target", str(site), str(wheel)], check=True, capture_output=True, timeout=300)
    work = tmp_path / "work"
    work.mkdir()
    env = {k: v for k, v in os.environ.items() if not k.startswith("MCD_")}
    env |= {"PYTHONPATH": str(site), "OMP_NUM_THREADS": "1"}

    def mcd(*args: str, check: bool = True) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, *args], cwd=work, env=env, capture_output=True, text=True,
                              check=check, timeout=600)

    where = mcd("-c",
    "import mcd, mcd.core.paths as p; print(mcd.__file__); print(p.CONF_DIR)").stdout.split()
    assert all(Path(w).is_relative_to(site) for w in where), where
    groups = mcd("-m", "mcd.run", "--help").stdout
    assert "paths: default" in groups
    shipped = ", ".join(sorted(f.stem for f in (REPO / "mcd" / "conf" / "experiment").glob("*.yaml")))
    assert f"experiment: {shipped}\n" in groups and "F_paper_head, " in shipped  # every experiment, installed
    row_c = OmegaConf.create(mcd("-m", "mcd.run", "+experiment=C", "--cfg", "job").stdout)
    assert {s: row_c.method[s] for s in SWITCHES} == COMPONENTS["C"]["switches"]
    refused = mcd("-m", "mcd.render", f"paths.scenes_dir={tmp_path / 'nowhere'}", check=False)
    assert refused.returncode != 0
    assert "paths.scenes_dir=" in refused.stderr and "no such folder" in refused.stderr
    assert not (work / "data").exists()
    cbox = Path(where[1]).parent / "scenes" / "cbox" / "scene.xml"
    mcd("-m", "mcd.denoise.render_frames", str(cbox), "frames", "--frames", "2", "--width", "32",
        "--height", "32", "--gbuffer-spp", "4")
    denoise = str(site / "bin" / "mcd-denoise")  # the console script the wheel installs
    if importlib.util.find_spec("pyoidn") is None:
        out = mcd(denoise, "frames", "-o", "out", "--experiment", "oidn", check=False)
        assert out.returncode != 0 and "pip install 'mcd[oidn]'" in out.stderr
        return
    mcd(denoise, "frames", "-o", "out", "--experiment", "oidn")
    assert sorted(p.name for p in (work / "out").glob("*.exr")) == ["cbox_0000.exr", "cbox_0001.exr"]

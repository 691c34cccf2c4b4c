"""The wheel carries what an installed ``mcd`` reads at run time (issue 31 step 2; docs/architecture.md,
"Layers"): the Hydra configs, the vendored scenes and the bundled checkpoints, so that ``mcd-denoise`` and
``python -m mcd.run`` work from any directory after ``pip install .``."""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

from mcd.paths import CONF_DIR, PACKAGE_DIR, VENDORED_SCENES_DIR

REPO = Path(__file__).resolve().parents[1]


def _files(folder: Path) -> set[str]:
    return {p.relative_to(PACKAGE_DIR.parent).as_posix() for p in folder.rglob("*")
            if p.is_file() and "__pycache__" not in p.parts and p.suffix != ".md"}


def test_the_wheel_carries_conf_scenes_and_bundles(tmp_path):
    """Build the wheel from a copy of the sources (so the checkout gets no build folder) and compare its
    files with the package's data folders."""
    src = tmp_path / "src"
    shutil.copytree(PACKAGE_DIR, src / "mcd", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copy(REPO / "pyproject.toml", src)
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(tmp_path / "dist"), str(src)], check=True, capture_output=True, timeout=300)
    (wheel,) = (tmp_path / "dist").glob("mcd-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    wanted = (_files(CONF_DIR) | _files(VENDORED_SCENES_DIR) | _files(PACKAGE_DIR / "bundled")
              | _files(PACKAGE_DIR / "reporting" / "viewer_page"))
    assert "mcd/reporting/viewer_page/viewer.js" in wanted
    assert "mcd/conf/config.yaml" in wanted and "mcd/scenes/cbox/scene.xml" in wanted
    assert wanted - names == set(), "package data missing from the wheel: pyproject.toml [tool.setuptools]"
    assert {"mcd/run.py", "mcd/denoise/cli.py", "mcd/bench/__main__.py"} <= names

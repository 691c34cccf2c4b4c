"""Where the package's own files are, resolved once (docs/architecture.md, "Layers"): the repository root, the
Hydra config folder and the vendored scenes.

Data and scenes that are not vendored come from the config (``paths.data_dir``, ``paths.scenes_dir``), never
from here; this module only names files that travel with the code.
"""

from __future__ import annotations

from pathlib import Path

#: The ``mcd`` package folder.
PACKAGE_DIR = Path(__file__).resolve().parent
#: The checkout the package was imported from (in an installed package: the folder above it, which holds no
#: checkout; :func:`mcd.provenance.git_commit` then says ``unknown``).
REPO_ROOT = PACKAGE_DIR.parent
#: The Hydra config folder (``conf/config.yaml`` and its groups).
CONF_DIR = REPO_ROOT / "conf"
#: The small scenes vendored with the code (docs/scenes.md).
VENDORED_SCENES_DIR = REPO_ROOT / "scenes"

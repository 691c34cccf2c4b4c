"""Where the package's own files are, resolved once (docs/architecture.md, "Layers"): the Hydra config folder
and the vendored scenes, both inside the package so that an installed wheel has them, and the checkout.

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
#: The Hydra config folder (``conf/config.yaml`` and its groups), package data (``conf`` at the repository
#: root is a link to it).
CONF_DIR = PACKAGE_DIR / "conf"
#: The small scenes vendored with the code (docs/scenes.md), package data (``scenes`` at the repository root
#: is a link to it).
VENDORED_SCENES_DIR = PACKAGE_DIR / "scenes"

"""A model capacity profile (``conf/capacity/``) as ``mcd.denoise`` needs it (docs/denoise.md); the composed
config of an experiment without weights (``oidn``, ``noisy``) is :func:`mcd.config.compose.compose`'s."""

from __future__ import annotations

from typing import Any

from omegaconf import OmegaConf

from mcd.config.compose import experiment_names
from mcd.core.paths import CONF_DIR


def capacity_profile(name: str) -> dict[str, Any]:
    """The widths of capacity profile ``name`` (``conf/capacity/<name>.yaml``); ValueError naming the
    choices."""
    path = CONF_DIR / "capacity" / f"{name}.yaml"
    if not path.is_file():
        choices = sorted(p.stem for p in (CONF_DIR / "capacity").glob("*.yaml"))
        raise ValueError(f"--capacity={name}: no capacity profile conf/capacity/{name}.yaml; choose one of "
                         f"{choices}")
    return OmegaConf.to_container(OmegaConf.load(path), resolve=True)  # type: ignore[return-value]


def check_experiment(name: str) -> None:
    """ValueError naming ``--experiment=name`` and the valid names
    (:func:`mcd.config.compose.experiment_names`), if there is no such experiment."""
    names = experiment_names()
    if name not in names:
        raise ValueError(f"--experiment={name}: no such experiment (+experiment={name}); choose one of "
                         f"{', '.join(names)}")

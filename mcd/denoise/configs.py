"""The repository's configs as ``mcd.denoise`` needs them: a model capacity profile (``conf/model/``) and the
composed config of an experiment without weights (``oidn``, ``noisy``; docs/denoise.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf

CONF_DIR = Path(__file__).resolve().parents[2] / "conf"


def model_profile(name: str) -> dict[str, Any]:
    """The widths of capacity profile ``name`` (``conf/model/<name>.yaml``); ValueError naming the choices."""
    path = CONF_DIR / "model" / f"{name}.yaml"
    if not path.is_file():
        choices = sorted(p.stem for p in (CONF_DIR / "model").glob("*.yaml"))
        raise ValueError(f"--model={name}: no capacity profile conf/model/{name}.yaml; choose one of "
                         f"{choices}")
    return OmegaConf.to_container(OmegaConf.load(path), resolve=True)  # type: ignore[return-value]


def compose(*overrides: str) -> DictConfig:
    """The root config (``conf/config.yaml``) with Hydra ``overrides``, as ``python -m mcd.run`` sees it."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    with initialize_config_dir(config_dir=str(CONF_DIR), version_base=None):
        return hydra_compose("config", overrides=list(overrides))

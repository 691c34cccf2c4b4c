"""The run config composed outside ``python -m mcd.run`` (docs/architecture.md, "Config"): one function,
so that tools, the denoise command and tests see exactly what a run sees."""

from __future__ import annotations

from collections.abc import Iterable

from omegaconf import DictConfig

from mcd.paths import CONF_DIR


def compose(overrides: Iterable[str] = ()) -> DictConfig:
    """The root config (``conf/config.yaml``) with Hydra ``overrides``, as ``python -m mcd.run`` composes it
    (without Hydra's own ``hydra.*`` run keys resolved)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        return hydra_compose(config_name="config", overrides=list(overrides))

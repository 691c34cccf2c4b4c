"""The one place configs are composed (docs/architecture.md, "Config"): :func:`compose` for tools, the denoise
command and tests, :func:`hydra_main` for the Hydra commands (``mcd.run``, ``mcd.render``, ``mcd.plan``,
``mcd.data.pack``, ``mcd.tools.check_paths``), so that every one sees exactly what a run sees.

The experiment group holds ``conf/experiment/*.yaml`` (the baselines and references) and, registered here in
Hydra's ConfigStore from the component table (:data:`mcd.methods.COMPONENTS`), rows A-M: the table is the one
source of each row's switches (docs/method.md, "Component study").
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from omegaconf import DictConfig

from mcd.methods import COMPONENTS, component_experiment
from mcd.paths import CONF_DIR


def register_experiments() -> None:
    """Store rows A-M in Hydra's ConfigStore as group ``experiment``, package ``_global_`` (as the yaml files
    of ``conf/experiment/`` are), so ``+experiment=C`` works wherever a config is composed. Idempotent; a
    multirun's joblib workers receive the store with Hydra's state."""
    from hydra.core.config_store import ConfigStore

    store = ConfigStore.instance()
    for row in COMPONENTS:
        store.store(group="experiment", name=row, node=component_experiment(row), package="_global_")


def experiment_names() -> list[str]:
    """Every experiment (``+experiment=<name>``): rows A-M first, then ``conf/experiment/*.yaml`` sorted."""
    return [*COMPONENTS, *sorted(p.stem for p in (CONF_DIR / "experiment").glob("*.yaml"))]


def compose(overrides: Iterable[str] = ()) -> DictConfig:
    """The root config (``conf/config.yaml``) with Hydra ``overrides``, as ``python -m mcd.run`` composes it
    (without Hydra's own ``hydra.*`` run keys resolved)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    register_experiments()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        return hydra_compose(config_name="config", overrides=list(overrides))


def hydra_main(task: Callable[[DictConfig], Any]) -> Callable[[], Any]:
    """``@hydra.main`` on the root config (``conf/config.yaml``) with rows A-M registered: the decorator of
    every Hydra command."""
    import hydra

    register_experiments()
    return hydra.main(config_path=str(CONF_DIR), config_name="config", version_base="1.3")(task)

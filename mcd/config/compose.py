"""The one place configs are composed (docs/architecture.md, "Config"): :func:`compose` for tools, the denoise
command and tests, :func:`hydra_main` for the Hydra commands (``mcd.run``, ``mcd.render``, ``mcd.plan``,
``mcd.pack``, ``mcd.check_paths``), so that every one sees exactly what a run sees.

The experiment group holds ``conf/experiment/*.yaml`` (the baselines and references) and, registered here in
Hydra's ConfigStore from the component table (:data:`mcd.config.methods.COMPONENTS`), rows A-M: the table is
the one source of each row's switches (docs/method.md, "Component study").

It is also the one place that knows the config groups renamed since (:data:`RENAMED_GROUPS`): an override
naming an old group is refused before any work (:func:`check_overrides`, in :func:`compose`; on a command
line, :func:`exit_on_renamed`), and a config saved under an old name reads as today's (:func:`upgrade_saved`).
"""

from __future__ import annotations

import functools
import os
import re
import sys
from collections.abc import Callable, Iterable, Mapping
from typing import Any

from omegaconf import DictConfig, OmegaConf, open_dict

from mcd.config.methods import COMPONENTS, component_experiment
from mcd.core.paths import CONF_DIR

#: Config groups renamed, old name -> today's: ``model`` (a capacity profile) is ``capacity``
#: (``conf/capacity/``, docs/architecture.md "Config groups").
RENAMED_GROUPS: dict[str, str] = {"model": "capacity"}
#: Keys a saved record holds under an old name: the groups, and the run record's choice of the capacity group
#: (``metrics.json``, mcd/lit/run_record.py).
RENAMED_KEYS: dict[str, str] = {**RENAMED_GROUPS, "model_profile": "capacity_profile"}


def check_overrides(overrides: Iterable[str]) -> None:
    """ValueError for the first override that names a renamed group (``model=paper``,
    ``model.rae.bottleneck=8``, ``+model=cpu``, ``~model``), saying what to type instead
    (``capacity=paper``)."""
    for override in overrides:
        key = override.lstrip("+~").split("=", 1)[0]
        head = key.split("@", 1)[0].split(".", 1)[0].split("/", 1)[0]
        if head in RENAMED_GROUPS:
            new = RENAMED_GROUPS[head]
            fixed = override.replace(head, new, 1)
            raise ValueError(f"{override}: the config group '{head}' is now called '{new}' (conf/{new}/, the "
                             f"capacity profiles; docs/architecture.md); give {fixed}")


def exit_on_renamed(overrides: Iterable[str]) -> None:
    """End the command, when an override names a renamed group, with :func:`check_overrides`' message on one
    line (``error: ...``, no traceback) and exit status 2, before any work: the command-line check of the
    Hydra commands (:func:`hydra_main`) and of the tools that take Hydra overrides (``python -m mcd.bench``'s
    modes, the lab's ``tools/bundle_scores.py``); docs/architecture.md, "Config"."""
    exit_2_on(ValueError, check_overrides, overrides)


def upgrade_saved(saved: Any) -> Any:
    """A config saved before a group was renamed (a run's checkpoint or ``.hydra/`` files, a bundle's JSON, a
    bench row, Hydra's recorded choices, a ``metrics.json``), with each old key of :data:`RENAMED_KEYS` under
    its new name (``model:`` -> ``capacity:``). A mapping that already has the new key, or neither, comes back
    as it is; a ``DictConfig`` stays one (a copy), any other mapping becomes a plain ``dict``; anything else
    comes back as it is."""
    if not isinstance(saved, Mapping | DictConfig):
        return saved
    old = [k for k in RENAMED_KEYS if k in saved and RENAMED_KEYS[k] not in saved]
    if not old:
        return saved
    if isinstance(saved, DictConfig):
        upgraded = OmegaConf.create(OmegaConf.to_container(saved, resolve=False))
        with open_dict(upgraded):
            for k in old:
                upgraded[RENAMED_KEYS[k]] = upgraded.pop(k)
        return upgraded
    return {(RENAMED_KEYS[k] if k in old else k): v for k, v in saved.items()}


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
    (without Hydra's own ``hydra.*`` run keys resolved); an override of a renamed group is refused first
    (:func:`check_overrides`)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    overrides = list(overrides)
    check_overrides(overrides)
    register_experiments()
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        return hydra_compose(config_name="config", overrides=overrides)


def exit_on_invalid(cfg: DictConfig) -> None:
    """End the command with the first value that breaks its key's rule
    (:func:`mcd.core.config_rules.check_config`) on one line (``error: <key>=<value>: ...``, no traceback),
    exit status 2."""
    from mcd.core.config_rules import ConfigError, check_config

    exit_2_on(ConfigError, check_config, cfg)


def exit_2_on(error: type[Exception], check: Callable[[Any], object], value: Any) -> None:
    """``check(value)``; an ``error`` it raises ends the command with its message on one line (``error: ...``,
    no traceback) and exit status 2: the commands' pre-work refusals."""
    try:
        check(value)
    except error as err:
        print(f"error: {err}", file=sys.stderr)
        raise SystemExit(2) from None


def print_to_pipe(text: str) -> None:
    """Print ``text`` to stdout; a reader that closed the pipe early (``| head``) ends the command quietly."""
    try:
        print(text, flush=True)
    except BrokenPipeError:
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
        raise SystemExit(0) from None


def hydra_main(task: Callable[[DictConfig], Any] | None = None, *,
               job_errors: bool = False) -> Any:
    """``@hydra.main`` on the root config (``conf/config.yaml``) with rows A-M registered: the decorator of
    every Hydra command. Before any work:

    - an override on the command line that names a renamed group ends the command with
      :func:`check_overrides`' message and exit status 2, before Hydra composes anything;
    - the config is checked against every key's rule (:mod:`mcd.core.config_rules`): a single run composes it
      first (:func:`compose`) and ends with one ``error:`` line and exit status 2 before Hydra writes its run
      directory; the task checks it again (a sweep's job, or flags that Hydra composes alone), ending a single
      run the same way and raising :class:`mcd.core.config_rules.ConfigError` in a sweep's job or a direct
      call ``main(cfg)``, except with ``job_errors=True`` (``mcd.run``, whose preflight checks it and writes
      the job's ``error.json`` so that the sweep goes on).
    """
    if task is None:
        return functools.partial(hydra_main, job_errors=job_errors)
    import hydra

    register_experiments()

    @functools.wraps(task)
    def checked_task(cfg: DictConfig) -> Any:
        from hydra.core.hydra_config import HydraConfig
        from hydra.types import RunMode

        if HydraConfig.initialized() and HydraConfig.get().mode == RunMode.RUN:
            exit_on_invalid(cfg)
        elif not job_errors:
            from mcd.core.config_rules import check_config

            check_config(cfg)
        return task(cfg)

    main = hydra.main(config_path=str(CONF_DIR), config_name="config", version_base="1.3")(checked_task)

    @functools.wraps(main)
    def checked(*args: Any, **kwargs: Any) -> Any:
        overrides = [a for a in sys.argv[1:] if not a.startswith("-")]
        exit_on_renamed(overrides)
        from hydra.errors import HydraException
        from omegaconf.errors import OmegaConfBaseException

        if HELP_FLAGS & set(sys.argv[1:]):
            try:
                text = app_help(overrides, sys.modules[task.__module__].__doc__)
            except (HydraException, OmegaConfBaseException) as err:
                print(f"error: {err}", file=sys.stderr)
                raise SystemExit(2) from None
            print_to_pipe(text)
            return None
        if len(overrides) == len(sys.argv[1:]):  # a single run, no Hydra flags: check before Hydra writes
            try:
                cfg = compose(overrides)
            except (HydraException, OmegaConfBaseException, ValueError):
                cfg = None  # Hydra says what is wrong with the overrides, in its own words
            if cfg is not None:
                exit_on_invalid(cfg)
        return main(*args, **kwargs)

    return checked


#: The flags that print a Hydra command's help (:func:`app_help`); ``--hydra-help`` stays Hydra's own.
HELP_FLAGS = frozenset({"--help", "-h"})


def config_groups() -> dict[str, list[str]]:
    """Every config group a command line can pick from (``group=option``) and its options, sorted: the folders
    of ``conf/`` (nested ones as ``a/b``) with their ``*.yaml`` files, and the experiment rows registered in
    the ConfigStore (:func:`register_experiments`). Hydra's own groups (``hydra/...``) and private files
    (``_name.yaml``, included by other configs) are left out. Read from the file system, so it costs
    milliseconds where Hydra's ``--help`` builds a config repository for every group (docs/architecture.md,
    "Start-up")."""
    groups: dict[str, set[str]] = {}
    for yaml in CONF_DIR.rglob("*.yaml"):
        group = yaml.parent.relative_to(CONF_DIR).as_posix()
        if group != "." and group.split("/")[0] != "hydra" and not yaml.stem.startswith("_"):
            groups.setdefault(group, set()).add(yaml.stem)
    groups.setdefault("experiment", set()).update(COMPONENTS)
    return {group: sorted(groups[group]) for group in sorted(groups)}


def app_help(overrides: Iterable[str], doc: str | None) -> str:
    """The ``--help`` of a Hydra command (:func:`hydra_main`): the command's module docstring, its config
    groups (:func:`config_groups`) and the config the given overrides compose (:func:`compose`, unresolved),
    in the layout of Hydra's own help; ``--hydra-help`` lists Hydra's flags."""
    command = getattr(sys.modules["__main__"].__spec__, "name", None) or sys.argv[0]
    groups = "\n".join(f"{group}: {', '.join(options)}" for group, options in config_groups().items())
    config = OmegaConf.to_yaml(compose(overrides), resolve=False)
    about = re.sub(r":\w+:`([^`]*)`", r"\1", (doc or "").strip()).replace("``", "")
    return "\n\n".join([
        f"usage: python -m {command} [group=option ...] [key=value ...] [-m] [--cfg job] [--hydra-help]",
        about,
        "== Configuration groups ==\nCompose your configuration from those groups (group=option)", groups,
        "== Config ==\nOverride anything in the config (foo.bar=value)",
        f"{config}Hydra's own flags (-m, --cfg, --resolve, --info, ...): python -m {command} --hydra-help"])

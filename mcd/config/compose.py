"""The one place configs are composed (docs/architecture.md, "Config"): :func:`compose` for tools, the denoise
command and tests, :func:`hydra_main` for the Hydra commands (``mcd.run``, ``mcd.render``, ``mcd.plan``,
``mcd.pack``, ``mcd.check_paths``), so that every one sees exactly what a run sees.

The experiment group is the files of ``conf/experiment/``: rows A-M of the component study (each the paper's
switches of its row, which :data:`mcd.config.methods.COMPONENTS` reads), the baselines, the references and the
variants (docs/architecture.md, "Config").
"""

from __future__ import annotations

import functools
import os
import re
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from omegaconf import DictConfig, OmegaConf, open_dict

from mcd.config.methods import COMPONENTS
from mcd.core.paths import CONF_DIR


def experiment_names() -> list[str]:
    """Every experiment (``+experiment=<name>``, ``conf/experiment/<name>.yaml``): rows A-M in the component
    table's order first, then the others sorted."""
    files = {p.stem for p in (CONF_DIR / "experiment").glob("*.yaml")}
    return [*(row for row in COMPONENTS if row in files), *sorted(files - set(COMPONENTS))]


def compose(overrides: Iterable[str] = (), with_hydra: bool = False) -> DictConfig:
    """The root config (``conf/config.yaml``) with Hydra ``overrides``, as ``python -m mcd.run`` composes it
    (without Hydra's own ``hydra.*`` run keys resolved); ``with_hydra``: with Hydra's ``hydra`` node too (its
    ``hydra.run.dir`` resolves, :func:`check_run_dir`)."""
    from hydra import compose as hydra_compose
    from hydra import initialize_config_dir

    overrides = list(overrides)
    with initialize_config_dir(config_dir=str(CONF_DIR), version_base="1.3"):
        return hydra_compose(config_name="config", overrides=overrides, return_hydra_config=with_hydra)


def check_run_dir(cfg: DictConfig) -> None:
    """ValueError naming ``hydra.run.dir`` where the run directory of ``cfg`` (composed ``with_hydra``;
    changed here) is a file, lies below one, or cannot be written (a read-only mount): Hydra makes it and
    opens its log there before any of the command's code runs, and ended in its own OSError traceback. The
    path is read as Hydra reads it (no ``~`` expansion), up to the default's ``${run_id:}``, a per-process
    token whose resolver the commands register later (``mcd.lit.run_dir``); a path that does not resolve here
    is left to Hydra."""
    from omegaconf.errors import OmegaConfBaseException

    from mcd.core.paths import writable_folder_to_be

    raw = str(OmegaConf.to_container(cfg.hydra.run, resolve=False)["dir"])
    with open_dict(cfg):
        cfg.hydra.run.dir = raw.split("${run_id:}")[0] or "."
    try:
        path = Path(str(OmegaConf.select(cfg, "hydra.run.dir")))
    except OmegaConfBaseException:
        return
    writable_folder_to_be("hydra.run.dir", path)


def check_unclaimed(cfg: DictConfig, outputs: Iterable[str], records: Iterable[str]) -> None:
    """ValueError naming ``hydra.run.dir`` (resolved by :func:`check_run_dir`) where that folder holds entries
    named like what the command writes there (``outputs``) but none of a run's own records (``records``): a
    folder of the user's, whose files the run would write over (its own ``frames.csv``, ``curve.csv``,
    ``logs/``, ...). A run's own directory (finished, interrupted or a DDP rank's) holds its records; a new or
    empty folder is taken as before."""
    from omegaconf.errors import OmegaConfBaseException

    try:
        path = Path(str(OmegaConf.select(cfg, "hydra.run.dir")))
    except OmegaConfBaseException:
        return
    if not path.is_dir() or any((path / name).exists() for name in records):
        return
    clash = sorted(name for name in outputs if (path / name).exists() or (path / name).is_symlink())
    if clash:
        raise ValueError(f"hydra.run.dir={path} holds {', '.join(clash)}, which a run writes, and no run's "
                         f"records ({', '.join(records)}): it is not a run directory, and a run there would "
                         "write over those files; give the run a new or empty folder (hydra.run.dir=<dir>)")


def check_run_links(cfg: DictConfig, names: Iterable[str]) -> None:
    """ValueError naming ``hydra.run.dir`` (resolved by :func:`check_run_dir`) where it holds a symbolic link
    at a name a run writes (``names``) or inside such a folder (:func:`mcd.core.links.check_links`)."""
    from omegaconf.errors import OmegaConfBaseException

    from mcd.core.links import check_links

    try:
        path = Path(str(OmegaConf.select(cfg, "hydra.run.dir")))
    except OmegaConfBaseException:
        return
    check_links("hydra.run.dir", path, names)


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


def hydra_main(task: Callable[[DictConfig], Any] | None = None, *, job_errors: bool = False,
               run_files: tuple[tuple[str, ...], tuple[str, ...]] = ((), ())) -> Any:
    """``@hydra.main`` on the root config (``conf/config.yaml``): the decorator of every Hydra command. Before
    any work the config is checked against every key's rule (:mod:`mcd.core.config_rules`): a single run
    composes it first (:func:`compose`) and ends with one ``error:`` line and exit status 2 before Hydra
    writes its run directory; the task checks it again (a sweep's job, or flags that Hydra composes alone),
    ending a single run the same way and raising
    :class:`mcd.core.config_rules.ConfigError` in a sweep's job or a direct call ``main(cfg)``, except with
    ``job_errors=True`` (``mcd.run``, whose preflight checks it and writes the job's ``error.json`` so
    that the sweep goes on). ``run_files``: ``(outputs, records)`` of :func:`check_unclaimed`, checked on a
    single run's directory before Hydra writes there (``mcd.run``); every other command's are its job log,
    ``<job>.log``, and Hydra's ``.hydra/`` (:func:`command_files`: a user's ``render.log`` in the folder given
    as ``hydra.run.dir`` had the render's log appended to it).
    """
    if task is None:
        return functools.partial(hydra_main, job_errors=job_errors, run_files=run_files)
    import hydra

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
    if run_files == ((), ()):
        run_files = command_files(task)

    @functools.wraps(main)
    def checked(*args: Any, **kwargs: Any) -> Any:
        overrides = [a for a in sys.argv[1:] if not a.startswith("-")]
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
                cfg = compose(overrides, with_hydra=True)
            except (HydraException, OmegaConfBaseException, ValueError):
                cfg = None  # Hydra says what is wrong with the overrides, in its own words
            if cfg is not None:
                exit_2_on(ValueError, check_run_dir, cfg)  # before Hydra makes it
                exit_2_on(ValueError, lambda c: check_unclaimed(c, *run_files), cfg)  # a user's folder
                exit_2_on(ValueError, lambda c: check_run_links(c, [*run_files[0], *run_files[1]]), cfg)
                with open_dict(cfg):
                    del cfg["hydra"]
                exit_on_invalid(cfg)
        return main(*args, **kwargs)

    return checked


def command_files(task: Callable[..., Any]) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """``(outputs, records)`` of a Hydra command other than ``mcd.run`` (:func:`check_unclaimed`): Hydra's
    job log, named after the command's module as Hydra names its job (``render.log`` for ``mcd.render``,
    ``conf/config.yaml``'s ``run_log``), and ``.hydra/``, which marks a folder a Hydra command wrote."""
    module = sys.modules.get(task.__module__)
    path = getattr(module, "__file__", None)  # ``python -m mcd.render`` runs it as ``__main__``
    name = Path(path).stem if path else task.__module__.rsplit(".", 1)[-1]
    return (f"{name}.log",), (".hydra",)


#: The flags that print a Hydra command's help (:func:`app_help`); ``--hydra-help`` stays Hydra's own.
HELP_FLAGS = frozenset({"--help", "-h"})


def config_groups() -> dict[str, list[str]]:
    """Every config group a command line can pick from (``group=option``) and its options, sorted: the folders
    of ``conf/`` (nested ones as ``a/b``) with their ``*.yaml`` files. Hydra's own groups (``hydra/...``)
    and private files (``_name.yaml``, included by other configs) are left out. Read from the file system, so
    it costs milliseconds where Hydra's ``--help`` builds a config repository for every group
    (docs/architecture.md, "Start-up")."""
    groups: dict[str, set[str]] = {}
    for yaml in CONF_DIR.rglob("*.yaml"):
        group = yaml.parent.relative_to(CONF_DIR).as_posix()
        if group != "." and group.split("/")[0] != "hydra" and not yaml.stem.startswith("_"):
            groups.setdefault(group, set()).add(yaml.stem)
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

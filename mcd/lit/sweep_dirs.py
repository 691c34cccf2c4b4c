"""A sweep's job directories, checked before any job runs (docs/reliability.md, "Campaign fixes").

Each job of a sweep runs in ``<hydra.sweep.dir>/<hydra.sweep.subdir>``, and ``python -m mcd.run`` skips a
directory that holds a finished run of the same job and refuses one of another job (``mcd.run``). The named
sweeps' subdirs hold the experiment and the budget only (``sweeps/_sweep_dirs.yaml``), so a grid over another
key (``train.lr=0.001,0.002``, ``seed=0,1``) put its jobs into one directory: the second was skipped as
"finished" or ended the sweep in a FileExistsError, after the first had trained. :func:`check_sweep` runs
from :class:`mcd.lit.hydra_callbacks.SweepDirs` when the sweep starts, before the sweeper writes anything:
it names ``hydra.sweep.dir`` where that folder cannot be made or written, and the jobs that would share
a directory with the overrides that tell them apart and the two ways out (``sweep_tag``,
``hydra.sweep.subdir``).
The grid is the sweeper's own (:func:`grid`: ``hydra.sweeper.params`` and the command line's lists, less the
jobs ``sweep_plan.seeds_only_where`` leaves out under :class:`mcd.lit.sweep_plan.PlannedSweeper`), and each
job's directory is read from its config as the launcher composes it.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from omegaconf import DictConfig, OmegaConf, open_dict

from mcd.core.paths import writable_folder_to_be

if TYPE_CHECKING:
    from hydra.core.config_loader import ConfigLoader


def grid(config: DictConfig, loader: ConfigLoader) -> list[list[str]]:
    """The jobs (each a list of overrides) the sweeper of ``config`` (the sweep's config, with ``hydra``)
    runs, in its order, where it is Hydra's basic sweeper or :class:`mcd.lit.sweep_plan.PlannedSweeper` (none
    for another sweeper); ``loader``: Hydra's config loader."""
    from hydra._internal.core_plugins.basic_sweeper import BasicSweeper
    from hydra.core.override_parser.overrides_parser import OverridesParser

    from mcd.lit.sweep_plan import PlannedSweeper, kept_jobs

    target = str(config.hydra.sweeper.get("_target_", "")).rsplit(".", 1)[-1]
    if target not in (BasicSweeper.__name__, PlannedSweeper.__name__):
        return []  # another sweeper's grid (Optuna's, ...) is its own
    params = [f"{k}={v}" for k, v in (config.hydra.sweeper.get("params") or {}).items()]
    params += list(OmegaConf.to_container(config.hydra.overrides.task, resolve=False))  # type: ignore[arg-type]
    overrides = OverridesParser.create(config_loader=loader).parse_overrides(params)
    jobs = [list(j) for batch in BasicSweeper.split_arguments(overrides, None) for j in batch]
    if target == PlannedSweeper.__name__:
        jobs = kept_jobs(jobs, config)
    return jobs


def check_sweep(config: DictConfig, loader: ConfigLoader) -> None:
    """ValueError naming ``hydra.sweep.dir`` where it cannot be made or written, or the jobs of the sweep
    of ``config`` that would run in one directory (module docstring). ``loader``: Hydra's config loader, which
    composes each job's config as the launcher does (``load_sweep_config``)."""
    sweep_dir = Path(str(config.hydra.sweep.dir))
    check_tag(config.get("sweep_tag"), sweep_dir)
    writable_folder_to_be("hydra.sweep.dir", sweep_dir)
    check_sweep_record(sweep_dir)
    jobs = grid(config, loader)
    seen: dict[str, int] = {}
    for num, job in enumerate(jobs):
        cfg = loader.load_sweep_config(config, job)
        with open_dict(cfg):
            cfg.hydra.job.num = cfg.hydra.job.id = num
        subdir = str(cfg.hydra.sweep.subdir)
        if Path(subdir).is_absolute() or ".." in Path(subdir).parts:
            raise ValueError(f"hydra.sweep.subdir={subdir!r} (job {num}): a job's folder lies below "
                             f"hydra.sweep.dir ({sweep_dir}); give a relative path without '..'")
        first = seen.setdefault(subdir, num)
        if first != num:
            raise ValueError(_collision(jobs, first, num, sweep_dir / subdir, config))


#: The sweep's record that Hydra writes in ``hydra.sweep.dir`` when the sweep starts.
SWEEP_RECORD = "multirun.yaml"


def check_sweep_record(sweep_dir: Path) -> None:
    """ValueError naming ``hydra.sweep.dir`` where its ``multirun.yaml``, which Hydra replaces when the sweep
    starts, is not an earlier sweep's record (a mapping holding ``hydra.mode``): a user's file of that name
    was replaced without a word, exit 0. A link, or a file whose bytes other names share, is refused too."""
    path = sweep_dir / SWEEP_RECORD
    if not path.exists() and not path.is_symlink():
        return
    why = None
    if path.is_symlink():
        why = f"a symbolic link to {path.resolve()}"
    elif not path.is_file():
        why = "not a regular file"
    elif path.stat().st_nlink > 1:
        why = "a file whose bytes other names share (a hard link)"
    else:
        try:
            record = OmegaConf.load(path)
        except Exception:  # noqa: BLE001 - any unreadable file is not Hydra's record
            record = None
        if not (isinstance(record, DictConfig) and isinstance(record.get("hydra"), DictConfig)
                and OmegaConf.select(record, "hydra.mode", default=None) is not None):
            why = "not a sweep's record"
    if why is not None:
        raise ValueError(f"hydra.sweep.dir={sweep_dir} holds {SWEEP_RECORD}, {why}, which the sweep would "
                         "replace with its own record: give the sweep a new or empty folder "
                         "(hydra.sweep.dir=<dir>), or move that file")


def check_tag(tag: object, sweep_dir: Path) -> None:
    """ValueError naming ``sweep_tag`` unless it is a suffix of one folder name (no ``/``): the named sweeps
    append it to ``multirun/<sweep>/<data profile>`` (``sweeps/_sweep_dirs.yaml``), and
    ``sweep_tag=/../../../x`` put the sweep's jobs outside ``multirun/`` and the working directory."""
    if tag is not None and ("/" in str(tag) or "\\" in str(tag)):
        raise ValueError(f"sweep_tag={tag!r}: a suffix of the sweep's folder name, such as sweep_tag=_ep5, "
                         f"without '/' (it would put the sweep in {sweep_dir}); to sweep elsewhere give "
                         "hydra.sweep.dir=<dir>")


def _collision(jobs: list[list[str]], first: int, second: int, folder: Path, config: DictConfig) -> str:
    """The message for jobs ``first`` and ``second`` of ``jobs`` sharing ``folder``."""
    from mcd.lit.sweep_plan import job_values

    a, b = job_values(jobs[first]), job_values(jobs[second])
    differ = [k for k in a if a[k] != b.get(k)] + [k for k in b if k not in a]
    told = ", ".join(f"{k}={a.get(k, '(unset)')} / {b.get(k, '(unset)')}" for k in differ)
    subdir = OmegaConf.to_container(config.hydra.sweep, resolve=False)["subdir"]  # type: ignore[index]
    key = differ[0] if differ else "<key>"
    return (f"jobs {first} and {second} of this sweep would run in one directory, {folder} ({told}): "
            f"hydra.sweep.subdir={subdir} does not hold {', '.join(differ) or 'what tells them apart'}, so "
            "the second would be skipped as finished or refused as another job's. Give each its own "
            f"directory: add the key to the subdir (hydra.sweep.subdir='{subdir}_{key.split('.')[-1]}"
            f"${{{key}}}'), or sweep one value at a time, each with its own sweep_tag (sweep_tag=_<name>). "
            "Nothing was run")

"""A Hydra sweeper that plans a sweep before it runs it (docs/benchmark.md "Scaling study";
``conf/hydra/sweeper/planned.yaml``, chosen by ``conf/sweep/scaling.yaml``).

It is Hydra's basic sweeper (the grid of ``hydra.sweeper.params`` and the command line's lists, one job per
combination, each through ``python -m mcd.run``: its own directory, ``error.json``, ``ckpt_path=auto``) with
three additions, all read from the root config's ``sweep_plan`` block:

- ``seeds_only_where``: a job of a seed other than the config's ``seed`` runs only where each listed key has
  one of the listed values (the scaling study: seeds 1 and 2 only at 3000 steps on ``small`` and ``medium``);
  the plan says how many jobs of the grid it leaves out;
- before any job starts, the plan: every job's CPU-hours of training, ``train.max_steps`` x the seconds of
  one optimiser step measured here as the job trains it (:func:`mcd.lit.workload.train_step`, the rule of
  ``python -m mcd.plan``: the module's training step on ``train.batch_size`` synthetic clips in the
  configured precision and layout, CPU seconds of one thread), per cell and in all; rendering the stores and
  the data loader are not in it (``python -m mcd.plan data=<profile>`` says what rendering costs);
- a grid whose CPU-hours exceed ``cpu_hours_limit`` is refused, before anything is written, unless
  ``allow_large=true``; ``dry_run=true`` prints the plan and runs nothing.
"""

from __future__ import annotations

import logging
import sys
from collections.abc import Callable, Iterable, Mapping
from typing import Any

from hydra._internal.core_plugins.basic_sweeper import BasicSweeper
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.core.override_parser.types import Override
from omegaconf import DictConfig, OmegaConf

log = logging.getLogger("mcd.run")


def job_values(job: Iterable[str]) -> dict[str, str]:
    """A job's overrides (``["+experiment=F", "data=small", ...]``) as ``{key: value}``, without Hydra's
    ``+``/``++``/``~`` prefixes."""
    return {k.lstrip("+~"): v for k, _, v in (o.partition("=") for o in job)}


def keep(job: Mapping[str, str], base_seed: int, only_where: Mapping[str, Iterable[Any]] | None) -> bool:
    """Whether a job runs: always at the config's seed, at another seed only where every key of
    ``only_where`` has one of its values (values compared as strings)."""
    if not only_where or int(job.get("seed", base_seed)) == base_seed:
        return True
    return all(str(job.get(k)) in {str(v) for v in values} for k, values in only_where.items())


def kept_jobs(grid: list[list[str]], config: DictConfig) -> list[list[str]]:
    """The jobs of ``grid`` that run under ``config``'s ``sweep_plan.seeds_only_where`` (:func:`keep`)."""
    only = (config.get("sweep_plan") or {}).get("seeds_only_where")
    only = OmegaConf.to_container(only) if only is not None else None
    base = int(config.get("seed", 0))
    return [j for j in grid if keep(job_values(j), base, only)]  # type: ignore[arg-type]


#: The keys that shape a training step, besides the method (``experiment``) and ``capacity``: jobs that agree
#: on them share one measurement (:func:`plan_rows`).
STEP_KEYS = ("data.train_crop", "data.clip_len", "train.batch_size", "train.grad_frames",
             "train.channels_last", "train.compile", "trainer.precision", "budget", "method", "loss")


def plan_rows(jobs: list[list[str]], job_config: Callable[[list[str]], DictConfig],
              step_seconds: Callable[[DictConfig], float]) -> list[dict[str, Any]]:
    """One row per cell (data, steps, experiment) of ``jobs`` (each a list of overrides): its seeds, the
    seconds of one optimiser step of its config (``job_config(job)``; ``step_seconds``, asked once per
    experiment, capacity and values of :data:`STEP_KEYS`), and its CPU-hours over its jobs."""
    cells: dict[tuple[str, int, str], list[int]] = {}
    configs: dict[tuple[str, int, str], DictConfig] = {}
    for job in jobs:
        cfg = job_config(job)
        steps = cfg.train.get("max_steps")
        if steps is None:
            raise ValueError(f"job {job}: train.max_steps is null; a planned sweep's budget is a number of "
                             "optimiser steps (set train.max_steps)")
        key = (str(cfg.data.name), int(steps), str(cfg.experiment))
        cells.setdefault(key, []).append(int(cfg.seed))
        configs[key] = cfg
    measured: dict[tuple, float] = {}
    rows = []
    for (data, steps, experiment), seeds in cells.items():
        cfg = configs[data, steps, experiment]
        what = (experiment, OmegaConf.to_yaml(cfg.capacity),
                *(str(OmegaConf.select(cfg, k, default=None)) for k in STEP_KEYS))
        if what not in measured:
            measured[what] = step_seconds(cfg)
        rows.append({"data": data, "steps": steps, "experiment": experiment, "seeds": sorted(seeds),
                     "step_s": measured[what], "cpu_h": len(seeds) * steps * measured[what] / 3600})
    return rows


def plan_lines(rows: list[dict[str, Any]], limit: float) -> list[str]:
    """The printed plan: a line per cell, then the grid's total against ``limit``."""
    total, jobs = sum(r["cpu_h"] for r in rows), sum(len(r["seeds"]) for r in rows)
    out = [f"{'data':8} {'steps':>6} {'experiment':12} {'seeds':8} {'s/step':>7} {'CPU-h':>7}"]
    out += [f"{r['data']:8} {r['steps']:>6} {r['experiment']:12} {','.join(map(str, r['seeds'])):8} "
            f"{r['step_s']:>7.3f} {r['cpu_h']:>7.2f}" for r in rows]
    out.append(f"plan: {jobs} jobs, {total:.1f} CPU-hours of training in all (limit {limit:g}: "
               "sweep_plan.cpu_hours_limit; one optimiser step as the job trains it, measured here on one "
               "thread; rendering and the data loader not included)")
    return out


def measured_step_seconds(cfg: DictConfig) -> float:
    """CPU seconds of one optimiser step of ``cfg`` as its job trains it (:func:`mcd.lit.workload.train_step`:
    ``train.batch_size`` clips in the configured precision and layout, at ``data.train_crop``, or extrapolated
    to it from ``plan.step_crop`` and half of it where the crop is larger)."""
    from mcd.lit.workload import train_step

    return float(train_step(cfg, int(cfg.plan.step_crop))["seconds"])


class PlannedSweeper:
    """The job rule, the printed plan and its limit (module docstring), over Hydra's basic sweeper: the class
    Hydra instantiates, :class:`hydra_plugins.mcd_sweep_plan.planned_sweeper.PlannedSweeper`, is this and
    ``BasicSweeper``. Not a subclass of ``BasicSweeper`` here: Hydra's plugin scan runs the basic sweeper's
    module again in every new scan (a second command in one process), and its ``__init__`` calls
    ``super(BasicSweeper, self)`` with the module's new class, which a class built on the first one is not."""

    config: DictConfig | None
    hydra_context: Any
    max_batch_size: int | None

    def sweep(self, arguments: list[str]) -> Any:
        """Hydra's sweep; a dry run (``sweep_plan.dry_run=true``) prints the plan and writes nothing: Hydra's
        sweep saves ``<sweep dir>/multirun.yaml`` first, which replaced a finished sweep's record with the
        command of a sweep that ran no job."""
        assert self.config is not None and self.hydra_context is not None
        if not (self.config.get("sweep_plan") or {}).get("dry_run", False):
            return super().sweep(arguments)
        params = [*self._parse_config(), *arguments]
        parser = OverridesParser.create(config_loader=self.hydra_context.config_loader)
        overrides = parser.parse_overrides(params)
        self.split_arguments(overrides, self.max_batch_size)
        return []

    def split_arguments(self, overrides: list[Override],  # type: ignore[override]
                        max_batch_size: int | None) -> list[list[list[str]]]:
        """The basic sweeper's batches less the jobs ``sweep_plan.seeds_only_where`` drops, after printing the
        plan; one ``error:`` line naming ``sweep_plan.allow_large`` and exit 2 above its limit."""
        assert self.config is not None and self.hydra_context is not None
        settings = self.config.get("sweep_plan") or {}
        grid = [list(j) for batch in BasicSweeper.split_arguments(overrides, None) for j in batch]
        jobs = kept_jobs(grid, self.config)
        if len(jobs) < len(grid):  # named, so that seeds typed on the command line do not vanish unsaid
            log.info("sweep_plan.seeds_only_where=%s leaves out %d of the grid's %d jobs (seeds other than "
                     "seed=%d outside those cells; sweep_plan.seeds_only_where=null runs them)",
                     OmegaConf.to_container(settings.get("seeds_only_where")), len(grid) - len(jobs),
                     len(grid), int(self.config.get("seed", 0)))
        loader, config = self.hydra_context.config_loader, self.config

        def job_config(job: list[str]) -> DictConfig:
            """The job's config as its task sees it (without Hydra's own ``hydra`` node)."""
            cfg = loader.load_sweep_config(config, job)
            return OmegaConf.masked_copy(cfg, [k for k in cfg if k != "hydra"])

        rows = plan_rows(jobs, job_config, measured_step_seconds)
        limit = float(settings.get("cpu_hours_limit", float("inf")))
        for line in plan_lines(rows, limit):
            log.info(line)
        total = sum(r["cpu_h"] for r in rows)
        if total > limit and not settings.get("allow_large", False):  # one line, no traceback
            print(f"error: the sweep's plan is {total:.1f} CPU-hours of training, above "
                  f"sweep_plan.cpu_hours_limit={limit:g}: narrow the grid (e.g. fewer data profiles, budgets "
                  "or seeds on the command line) or add sweep_plan.allow_large=true to run it anyway. "
                  "Nothing was run.", file=sys.stderr)
            raise SystemExit(2)
        if settings.get("dry_run", False):
            return []
        chunks = BasicSweeper.split_overrides_to_chunks(jobs, max_batch_size)
        return [list(c) for c in chunks]

"""``python -m mcd.bench train``: training throughput of each method and training path on real batches of
the store (docs/training.md, "Throughput"); writes ``--out`` (default ``outputs/bench/train.csv`` under the
working directory, never a tracked file unless named) and prints each path's ratio to
``today`` (this project's fp32 training path before the throughput work).

A path is a set of training settings; each (method, profile, path) is measured in its own process (so that
its peak RSS is its own) by a real Lightning ``fit`` of ``--steps`` optimiser steps after ``--warmup`` steps,
on the profile's training clips (``train.batch_size`` clips of ``data.clip_len`` frames, ``data.train_crop``
crops), with the validation cadence of the path (validation time counts: it is part of what a run spends):

- ``today``: fp32, every clip frame run (the loss's ``frames_needed`` ignored), validation every epoch,
  a log row every step, contiguous weights;
- ``default``: the training profile's settings as configured (``train=cpu``: see docs/training.md);
  ``default-fp32`` the same in fp32 (what ``trainer.precision=auto`` picks where bf16 does not pay);
- ``fp32``: the clip frames the loss reads (all for temporal models), validation every
  ``train.val_every_steps``, a log row every 10 steps, contiguous weights;
- ``channels-last``: ``fp32`` with the weights in channels-last memory format (``train.channels_last``);
- ``tbptt``: ``fp32`` with ``train.grad_frames=2`` (temporal models only: the frames before the last two run
  without gradient); ``tbptt+channels-last`` both;
- ``bf16``: ``fp32`` with ``trainer.precision=bf16-mixed`` (where the CPU computes bf16 natively);
  ``bf16+channels-last`` both;
- ``compile``: ``default`` with ``train.compile=true`` (``torch.compile``, inductor; compilation happens
  in the warm-up steps, recompilation for validation counts).

``--allocators keep,system``: each path once per allocator setting (:mod:`mcd.core.allocator`; ``keep``, the
default, is what ``mcd.run`` sets; ``system`` is glibc's default); the ``allocator`` column says which ran.
``--pair``: also ``fp32`` as two concurrent jobs of one thread each (``x2 jobs``; steps/s summed) beside one
job on ``--threads`` threads, the question of docs/training.md "CPU threads".
Columns: ``method, profile, path, steps_per_s, pixels_per_s, peak_rss_mb, threads, cpu, steps_per_cpu_s,
allocator``
(pixels/s: crop pixels of the frames the network runs, times the batch, per second; steps per CPU-second of
the process, which other work on a shared machine disturbs far less than steps per second when the job runs
one thread: ``--threads 1``).
"""

from __future__ import annotations

import argparse
import csv
import json
import logging
import os
import resource
import subprocess
import sys
import tempfile
import time

import torch

from mcd.config.methods import CATALOGUE
from mcd.core import allocator
from mcd.core.machine import device_name
from mcd.core.paths import REPO_ROOT, writable_file_arg

log = logging.getLogger("mcd.bench.train")

#: The methods measured by default (mcd.config.methods: ``train_bench``).
METHODS = tuple(m.experiment for m in CATALOGUE if m.train_bench)
PATHS = ("today", "default", "default-fp32", "fp32", "channels-last", "tbptt", "tbptt+channels-last", "bf16",
         "bf16+channels-last", "compile")
COLUMNS = ("method", "profile", "path", "steps_per_s", "pixels_per_s", "peak_rss_mb", "threads", "cpu",
           "steps_per_cpu_s", "allocator")


def path_overrides(path: str) -> list[str]:
    """Hydra overrides of a path (see the module docstring)."""
    base = ["trainer.enable_progress_bar=false"]
    as_configured = {"default": [], "default-fp32": ["trainer.precision=32-true"],
                     "compile": ["train.compile=true"]}
    if path in as_configured:
        return [*base, *as_configured[path]]
    base += ["trainer.precision=32-true", "train.channels_last=false", "train.grad_frames=null"]
    if path == "today":
        return [*base, "train.val_every_steps=null", "train.val_every=1", "trainer.log_every_n_steps=1"]
    extra = {"fp32": [], "channels-last": ["train.channels_last=true"], "tbptt": ["train.grad_frames=2"],
             "bf16": ["trainer.precision=bf16-mixed"],
             "tbptt+channels-last": ["train.grad_frames=2", "train.channels_last=true"],
             "bf16+channels-last": ["trainer.precision=bf16-mixed", "train.channels_last=true"]}
    if path not in extra:
        raise ValueError(f"unknown training path {path!r}; expected one of {PATHS}")
    return [*base, *extra[path]]


def measure(method: str, profile: str, path: str, steps: int, warmup: int, threads: int,
            extra: list[str], memory: str) -> dict[str, object]:
    """One (method, profile, path) in this process, with ``--allocator`` ``memory``
    (:func:`mcd.core.allocator.apply`): steps/s of a Lightning fit after ``warmup`` steps."""
    import lightning as L

    from mcd.config.compose import compose
    from mcd.data import MCDDataModule, StoreBuilder
    from mcd.data.buffers import run_buffers
    from mcd.lit import DenoiseModule, budget
    from mcd.losses import build_loss

    policy = allocator.apply(memory)
    torch.set_num_threads(threads)
    cfg = compose([f"+experiment={method}", f"data={profile}", *path_overrides(path), *extra,
                   f"train.max_steps={steps + warmup}", "train.max_minutes=null"])
    L.seed_everything(0)
    from mcd.models import build

    model = build(cfg)
    buffers = run_buffers(model.required_buffers(), cfg.budget)
    store = StoreBuilder.from_cfg(cfg)
    store.ensure(buffers)
    dm = MCDDataModule(cfg, store, buffers, model.window)
    loss = build_loss(cfg)
    if path == "today":
        loss.frames_needed = None
    lit = DenoiseModule(cfg, model, loss)
    frames: list[int] = []

    class Clock(L.Callback):
        """Times the steps after warm-up and counts the frames each step runs."""

        started = cpu_started = 0.0

        def on_train_batch_start(self, trainer, module, batch, idx):  # noqa: ANN001
            if trainer.global_step == warmup:
                self.started, self.cpu_started = time.perf_counter(), time.process_time()
            steps_in_clip = batch["ref"].shape[1]
            frames.append(steps_in_clip - lit.clip_plan(steps_in_clip)[0])

    clock = Clock()
    trainer = L.Trainer(**budget.trainer_kwargs(cfg), callbacks=[clock, *budget.callbacks(cfg.train)],
                        logger=False,
                        enable_checkpointing=False, default_root_dir=tempfile.gettempdir())
    trainer.fit(lit, datamodule=dm)
    seconds = time.perf_counter() - clock.started
    cpu_seconds = time.process_time() - clock.cpu_started
    crop = int(cfg.data.train_crop)
    rate = steps / seconds
    return {"method": method, "profile": profile, "path": path, "steps_per_s": rate,
            "pixels_per_s": rate * int(cfg.train.batch_size) * crop * crop * (sum(frames[warmup:]) / steps),
            "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, "threads": threads,
            "cpu": device_name(torch.device("cpu")).rsplit(" (", 1)[0],
            "steps_per_cpu_s": steps / cpu_seconds, "allocator": policy}


def applicable(method: str, path: str) -> str | None:
    """Why ``path`` does not apply to ``method`` (None: it does)."""
    from mcd.config.compose import compose
    from mcd.lit.precision import cpu_bf16_supported
    from mcd.models import build

    if path.startswith("bf16") and not cpu_bf16_supported():
        return "this CPU has no native bf16"
    if path.startswith("tbptt") and not getattr(build(compose([f"+experiment={method}"])), "temporal_state",
                                                True):
        return "no temporal state"
    return None


def child(args: list[str]) -> dict[str, object]:
    """Runs :func:`measure` in a fresh process; returns its row."""
    env = dict(os.environ)
    out = subprocess.run([sys.executable, "-m", "mcd.bench", "train", "--child", *args],
                         capture_output=True, text=True, env=env, cwd=REPO_ROOT)
    if out.returncode != 0:
        raise RuntimeError(f"training benchmark {args[:3]} failed:\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def check_names(args: argparse.Namespace) -> str | None:
    """Why ``--methods``, ``--profiles``, ``--paths`` or ``--profile-methods`` name nothing to measure (empty,
    or an experiment, data profile or path that does not exist), naming the flag and what is valid; None
    when each names something. Asked before any job starts."""
    from mcd.config.compose import experiment_names
    from mcd.core.paths import CONF_DIR

    profiles = sorted(p.stem for p in (CONF_DIR / "data").glob("*.yaml"))
    valid = {"--methods": experiment_names(), "--profiles": profiles, "--paths": list(PATHS)}
    given = {"--methods": [args.methods], "--profiles": [args.profiles], "--paths": [args.paths]}
    for item in args.profile_methods:
        profile, sep, methods = item.partition("=")
        if not sep:
            return f"--profile-methods {item!r}: give PROFILE=M1,M2"
        given["--profiles"].append(profile)
        given["--methods"].append(methods)
    for flag, values in given.items():
        for value in values:
            names = [n for n in value.split(",") if n]
            unknown = sorted(set(names) - set(valid[flag]))
            if not names or unknown:
                return (f"{flag} {value!r}: {'none given' if not names else 'no ' + ', '.join(unknown)}; "
                        f"give one or more of {', '.join(sorted(valid[flag]))}")
    return None


def main(argv: list[str] | None = None) -> None:
    from mcd.denoise.arguments import int_in  # the numbers are checked before any job starts (0 steps ran
    # every job's warm-up, then failed each on a division by zero)

    ap = argparse.ArgumentParser(prog="python -m mcd.bench train", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("overrides", nargs="*", help="Hydra overrides for every job (default: capacity=cpu)")
    ap.add_argument("--methods", default=",".join(METHODS))
    ap.add_argument("--profiles", default="tiny,small")
    ap.add_argument("--profile-methods", action="append", default=[], metavar="PROFILE=M1,M2",
                    help="methods for one profile instead of --methods (repeatable), e.g. small=A,C,F")
    ap.add_argument("--paths", default=",".join(PATHS))
    ap.add_argument("--steps", type=int_in(1, 10**6), default=30, help="timed optimiser steps per path")
    ap.add_argument("--warmup", type=int_in(0, 10**6), default=4)
    ap.add_argument("--threads", type=int_in(1, 4096), default=os.cpu_count() or 1)
    ap.add_argument("--pair", action="store_true", help="also two concurrent 1-thread fp32 jobs")
    ap.add_argument("--out", type=writable_file_arg("--out"), default="outputs/bench/train.csv",
                    help="CSV to write (default: outputs/bench/train.csv)")
    ap.add_argument("--allocators", default="keep",
                    help="comma-separated: keep (mcd.run's setting, mcd/core/allocator.py) and/or system "
                         "(glibc's default)")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:  # one measurement: method profile path steps warmup threads allocator, overrides
        print(json.dumps(measure(args.methods, args.profiles, args.paths, args.steps, args.warmup,
                                 args.threads, args.overrides, args.allocators)))
        return
    allocators = [a for a in args.allocators.split(",") if a]
    if not allocators or set(allocators) - set(allocator.CHOICES):
        ap.error(f"--allocators {args.allocators!r}: give one or more of {', '.join(allocator.CHOICES)}")
    if (why := check_names(args)) is not None:  # each job failed on it, and --out became an empty table
        ap.error(why)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    rows: list[dict[str, object]] = []
    failed: list[str] = []
    per_profile = dict(p.split("=", 1) for p in args.profile_methods)
    for profile in [p for p in args.profiles.split(",") if p]:
        for method in [m for m in per_profile.get(profile, args.methods).split(",") if m]:
            # --out: the file checked here, not the default under the child's working folder (REPO_ROOT,
            # site-packages in an installed package), which the child's parser would check
            common = [f"--steps={args.steps}", f"--warmup={args.warmup}", f"--out={args.out.resolve()}",
                      *args.overrides]
            for path in [p for p in args.paths.split(",") if p]:
                why = applicable(method, path)
                if why:
                    log.info("%s %s %s: skipped (%s)", method, profile, path, why)
                    continue
                for memory in allocators:
                    try:
                        row = child([f"--methods={method}", f"--profiles={profile}", f"--paths={path}",
                                     f"--threads={args.threads}", f"--allocators={memory}", *common])
                    except RuntimeError as err:  # one path failing (e.g. a compiler error) loses no other
                        failed.append(f"{method} {profile} {path} {memory}: "
                                      f"{str(err).strip().splitlines()[-1]}")
                        log.warning("%s", err)
                        continue
                    rows.append(row)
                    log.info("%s %s %-13s %-6s %.2f steps/s", method, profile, path, memory,
                             row["steps_per_s"])
            if args.pair:
                cmd = [sys.executable, "-m", "mcd.bench", "train", "--child", f"--methods={method}",
                       f"--profiles={profile}", "--paths=fp32", "--threads=1",
                       f"--allocators={allocators[0]}", *common]
                procs = [subprocess.Popen(cmd, stdout=subprocess.PIPE, text=True, cwd=REPO_ROOT)
                         for _ in range(2)]
                pair = [json.loads(p.communicate()[0].strip().splitlines()[-1]) for p in procs]
                rows.append({**pair[0], "path": "fp32 x2 jobs", "threads": 1,
                             "steps_per_s": sum(r["steps_per_s"] for r in pair),
                             "pixels_per_s": sum(r["pixels_per_s"] for r in pair),
                             "steps_per_cpu_s": sum(r["steps_per_cpu_s"] for r in pair) / 2,
                             "peak_rss_mb": max(r["peak_rss_mb"] for r in pair)})
    if not rows:  # an earlier measurement at --out is not replaced by an empty table
        for line in failed:
            print(f"failed: {line}")
        sys.exit(f"error: no path was measured ({len(failed)} failed, the others skipped); "
                 f"{args.out} is left as it was")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        writer.writerows({k: r[k] for k in COLUMNS} for r in rows)
    print(f"{'method':10} {'profile':7} {'path':20} {'steps/s':>8} {'x today':>8} {'steps/cpu-s':>11} "
          f"{'x today':>8} {'Mpix/s':>7} {'RSS MB':>7}  allocator")
    for r in rows:
        today = next((t for t in rows if t["path"] == "today" and t["method"] == r["method"]
                      and t["profile"] == r["profile"] and t["allocator"] == r["allocator"]), None)
        ratio, cpu_ratio = ((r[k] / today[k] if today else float("nan"))
                            for k in ("steps_per_s", "steps_per_cpu_s"))
        print(f"{r['method']:10} {r['profile']:7} {r['path']:20} {r['steps_per_s']:8.2f} {ratio:8.2f} "
              f"{r['steps_per_cpu_s']:11.2f} {cpu_ratio:8.2f} {r['pixels_per_s'] / 1e6:7.2f} "
              f"{r['peak_rss_mb']:7.0f}  {r['allocator']}")
    print(f"{len(rows)} rows -> {args.out}")
    for line in failed:
        print(f"failed: {line}")


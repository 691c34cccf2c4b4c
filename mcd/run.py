"""``python -m mcd.run +experiment=F``: render (or load) the data, train, keep the best validation checkpoint,
test it on whole sequences, and write the run directory (docs/architecture.md, "Run directory").

Shape: :func:`build` (check the config, render or reuse the data, build model, datamodule, module, callbacks
and trainer), :func:`fit` (train within the budget, agree on the best checkpoint), :func:`run_test` (the test
recorder, ``mcd.lit.test_recorder``, writes ``frames.csv`` and ``samples/``), then :func:`run_record`, the
``metrics.json`` of ``mcd.lit.run_record``. Under ``trainer=ddp`` every process runs all of it; validation
metrics are averaged over the processes, rank 0 tests every frame and alone writes the run's files.

Overrides: ``paths.data_dir=<dir>``, ``hydra.run.dir=<dir>``, ``ckpt_path=<file>`` (resume training from a
checkpoint; ``auto``: from the run directory's ``last.ckpt`` if a killed run left one, as the sweeps do),
``trainer.precision=bf16-mixed`` (GPU), any ``train.*`` / ``data.*`` / ``method.*`` key.
Sweeps (``-m``): a job whose output directory already holds a complete ``metrics.json`` of the same job
(``mcd.lit.run_record.job_identity``) is skipped, one of another job is an error; a job that raises writes
``error.json`` (overrides, config, traceback) and the sweep goes on, then exits 1 naming the failed jobs
(``mcd.lit.hydra_callbacks.FailedJobs``). A single run re-raises.
"""

from __future__ import annotations

import contextlib
import dataclasses
import logging
import math
import time
import traceback
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from hydra.utils import instantiate
from omegaconf import DictConfig, OmegaConf

from mcd.config.compose import hydra_main
from mcd.config.preflight import check_augment, check_motion, check_run, check_train_store, samples_left_out
from mcd.core import allocator, links
from mcd.core.atomic_write import atomic_write_json
from mcd.core.machine import device_name
from mcd.core.provenance import git_commit
from mcd.lit import run_dir
from mcd.lit.run_record import SWITCHED_METHODS, RunRecord, check_same_job, claim_run_dir, is_complete
from mcd.lit.run_summary import summary
from mcd.lit.workload import announce
from mcd.models.switches import check_switches, switch_row

if TYPE_CHECKING:  # imported where used, so that --help starts fast (docs/architecture.md, "Start-up")
    import lightning as L
    from lightning.pytorch.callbacks import ModelCheckpoint
    from torch import nn

    from mcd.data import MCDDataModule
    from mcd.lit import DenoiseModule, budget
    from mcd.lit.segments import TrainingSegments
    from mcd.lit.test_recorder import TestRecorder

log = logging.getLogger("mcd.run")


def write_error(out_dir: Path, cfg: DictConfig, overrides: list[str], err: BaseException) -> Path:
    """``error.json``: the job's overrides, its config and the traceback, written atomically (a new file
    each time: :class:`mcd.lit.hydra_callbacks.FailedJobs` tells this sweep's failures from earlier ones by
    it)."""
    path = out_dir / "error.json"
    atomic_write_json(path, {
        "error": f"{type(err).__name__}: {err}",
        "overrides": overrides,
        "config": OmegaConf.to_container(cfg, resolve=False),
        "traceback": traceback.format_exception(err),
    }, indent=2)
    return path


@dataclasses.dataclass
class Job:
    """What a run builds from its config (:func:`build`), for :func:`fit` and :func:`run_test`."""

    cfg: DictConfig  # the run's config (a transfer job's rewritten by mcd.lit.transfer.prepare)
    out_dir: Path
    model: nn.Module
    datamodule: MCDDataModule
    module: DenoiseModule
    trainer: L.Trainer
    best: ModelCheckpoint  # the best validation checkpoint
    curve: budget.LearningCurve
    segments: TrainingSegments  # which code trained which steps (mcd/lit/segments.py)
    recorder: TestRecorder
    trainable: bool  # False: the method is tested as built (or as transferred, without fine-tuning)
    resume: str | None  # ckpt_path: the checkpoint training resumes from
    transfer: dict[str, Any] | None
    data_report: dict[str, Any]  # the store's report (what it rendered, what it reused)
    data_settings: dict[str, Any]  # what determines the data, as the job's identity has it (before transfer)
    data_s: float
    precision: str  # the Lightning precision the trainer runs in (mcd.lit.precision)


@dataclasses.dataclass
class Fitted:
    """What training left: the checkpoint to test (None: the model as built) and why it stopped."""

    checkpoint: str | None
    best_val_psnr: float | None
    stop_reason: str
    seconds: float
    segments: list[dict[str, Any]]  # the training segments (mcd/lit/segments.py), read before testing


def resume_checkpoint(ckpt_path: str | None, out_dir: Path) -> str | None:
    """The checkpoint training resumes from: ``ckpt_path`` as given, or with ``ckpt_path=auto`` the run
    directory's own ``checkpoints/last.ckpt`` where a killed run left one (else None: a fresh start). The
    sweeps set ``auto`` (sweeps/_sweep_dirs.yaml), so a sweep run again after an interruption continues its
    unfinished jobs where they stopped instead of training them from the start.

    Without ``ckpt_path``, a directory that holds an interrupted run (``last.ckpt``, no complete
    ``metrics.json``) is refused with FileExistsError before anything is written: a fresh start there
    replaced its ``last.ckpt``, losing the training it held, and left its best checkpoint beside the new
    run's."""
    last = out_dir / "checkpoints" / "last.ckpt"
    if not ckpt_path and last.is_file() and not is_complete(out_dir / "metrics.json"):
        raise FileExistsError(
            f"{out_dir} holds an interrupted run ({last}, no metrics.json): resume it with ckpt_path=auto, "
            "or give this run its own directory (hydra.run.dir=<dir>); to start it again from scratch, "
            "delete the directory first")
    if ckpt_path != "auto":
        return ckpt_path or None
    if last.is_file():
        log.info("ckpt_path=auto: resuming the interrupted run from %s", last)
        return str(last)
    return None


def build(cfg: DictConfig, out_dir: Path, choices: dict[str, str] | None = None) -> Job:
    """Check the config, render (or reuse) the data, and build model, datamodule, module and trainer.

    Everything that can fail on the config alone fails before anything is rendered: impossible switches, the
    budget and image size (mcd.config.preflight), a missing or unfitting ``ckpt_path``, a run directory
    holding an interrupted run of another job (``mcd.lit.run_record.claim_run_dir``; ``choices``: Hydra's
    config-group choices, for the job's data profile).
    """
    import lightning as L
    from lightning.pytorch.callbacks import ModelCheckpoint

    from mcd.data import MCDDataModule, StoreBuilder
    from mcd.data.buffers import run_buffers
    from mcd.data.pack import pack
    from mcd.data.train_store import TrainStoreSettings, pack_command
    from mcd.lit import DenoiseModule, accelerator, budget, checkpoint, precision, progress, transfer
    from mcd.lit.segments import TrainingSegments, recorded_job
    from mcd.lit.test_recorder import TestRecorder
    from mcd.losses import build_loss
    from mcd.models import build as build_model

    if cfg.method.name in SWITCHED_METHODS:
        check_switches(cfg.method)
    check_run(cfg)  # budget and image size, before anything is rendered
    if (left_out := samples_left_out(cfg)) is not None:
        log.warning("%s", left_out)
    train_store = TrainStoreSettings.from_cfg(cfg)  # data.train_store.*, named if unknown
    resume = resume_checkpoint(cfg.get("ckpt_path"), out_dir)
    if resume and not Path(resume).is_file():
        what = "a folder, not a checkpoint file" if Path(resume).is_dir() else "no such checkpoint file"
        last = Path(resume) / "checkpoints" / "last.ckpt"
        hint = f"give {last}" if last.is_file() else "give a run's checkpoints/last.ckpt"
        raise FileNotFoundError(f"ckpt_path={resume}: {what} ({hint})")
    resumed = checkpoint.safe_load(resume, "ckpt_path") if resume else None
    # refuses an interrupted run of another job, and a checkpoint trained as another (its own record)
    held = None if resumed is None else (Path(resume), recorded_job(resumed, Path(resume)))
    job_record = claim_run_dir(out_dir, cfg, choices or {}, held)
    L.seed_everything(int(cfg.seed), workers=True)
    cfg, transfer_info = transfer.prepare(cfg)  # held-out scenes from trained weights (mcd/lit/transfer.py)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "resolved_config.yaml").write_text(OmegaConf.to_yaml(cfg, resolve=True))

    model = build_model(cfg)
    if resumed is not None:  # read safely, and refuse another experiment's checkpoint before anything renders
        weights = checkpoint.model_weights(resumed)
        checkpoint.check_fits(model, weights, "ckpt_path", resume)
    if transfer_info is not None:
        transfer.load_weights(model, transfer_info)
    buffers = run_buffers(model.required_buffers(), cfg.budget)
    check_motion(cfg, buffers)  # the motion buffer where the training clips cannot hold it, before rendering
    check_augment(cfg, buffers)  # data.augment.reverse with a motion buffer, before anything is rendered
    announce(cfg, "mcd.run", buffers, train=bool(cfg.method.get("trainable", True)))  # counts, no measuring
    loss = build_loss(cfg)  # a loss the clips cannot feed (L_t, clips of one frame), before anything renders
    needed = int(getattr(loss, "frames_needed", None) or 1)
    if bool(cfg.method.get("trainable", True)) and needed > int(cfg.data.clip_len):
        raise ValueError(f"data.clip_len={int(cfg.data.clip_len)}: the loss reads the last {needed} outputs "
                         f"of each clip (L_t, loss.w_t={cfg.loss.get('w_t')}); raise data.clip_len to "
                         f"{needed} or set loss.w_t=0")
    store = StoreBuilder.from_cfg(cfg)
    # a packed training store of another config, or without a buffer of this run, before anything is rendered
    check_train_store(cfg, buffers, pack_command(store.overrides, buffers))
    precision.check(str(cfg.trainer.get("precision", "auto")))  # named before anything is rendered
    accelerator.check(cfg.trainer.get("accelerator", "auto"), cfg.trainer.get("devices", 1))  # the same
    # the budget (train.max_steps, max_minutes, epochs: one at least) and the trainer.* keys, before anything
    # is rendered: a run without a budget rendered its whole store, then failed here
    trainer_kwargs = budget.trainer_kwargs(cfg)
    t0 = time.perf_counter()
    report = store.ensure(buffers)  # logs one line: what was rendered, what was reused
    if train_store.format == "array":  # training clips from the packed store
        packed = pack(cfg, store, buffers)  # resumes; reuses what is packed (docs/training_store.md)
        report["train_store"] = {k: packed[k] for k in ("root", "packed", "reused", "clamped_total")}
    data_s = time.perf_counter() - t0
    datamodule = MCDDataModule(cfg, store, buffers, model.window)
    module = DenoiseModule(cfg, model, loss)

    best = ModelCheckpoint(dirpath=out_dir / "checkpoints", filename="best-step{step:06d}",
                           auto_insert_metric_name=False, monitor="val/psnr", mode="max", save_top_k=1)
    # last.ckpt after every validation, replacing the previous one (save_last on `best` would write it only
    # with a new best, so a killed run resumed from an older epoch); budget.finish rewrites it when it
    # validates once more where the budget ended
    last = ModelCheckpoint(dirpath=out_dir / "checkpoints", filename="last", save_top_k=1,
                           enable_version_counter=False)
    curve = budget.LearningCurve(out_dir / "curve.csv")
    segments = TrainingSegments(git_commit(), job_record)
    recorder = TestRecorder(out_dir, cfg.train.get("sample_frames", ()))
    trainer = L.Trainer(**trainer_kwargs, default_root_dir=str(out_dir),
                        callbacks=[best, budget.OwnBest(best), last, curve, segments, recorder,
                                   *budget.callbacks(cfg.train),
                                   *progress.callbacks(cfg)],
                        logger=instantiate(cfg.logger, save_dir=str(out_dir)))
    trainable = bool(cfg.method.get("trainable", True))
    trainable = trainable and (transfer_info is None or transfer_info["finetune"])  # 0 epochs: test as is
    if trainable and not any(p.requires_grad for p in model.parameters()):
        raise ValueError(f"method.name={cfg.method.name!r} has no trainable parameters: set "
                         "method.trainable=false to test it without training")
    return Job(cfg=cfg, out_dir=out_dir, model=model, datamodule=datamodule, module=module, trainer=trainer,
               best=best, curve=curve, segments=segments, recorder=recorder, trainable=trainable,
               resume=resume or None, transfer=transfer_info, data_report=report,
               data_settings=job_record["data_settings"],
               data_s=data_s, precision=str(trainer_kwargs["precision"]))


def agreed_best(trainer: L.Trainer, best: ModelCheckpoint) -> tuple[str, float | None]:
    """The best checkpoint and its ``val/psnr``; RuntimeError on every process where the processes of a DDP
    run picked different ones (their validation metrics were not averaged over all of them)."""
    import torch

    score = None if best.best_model_score is None else float(best.best_model_score)
    ours = (best.best_model_path, score)
    picks: list[object] = [ours]
    if trainer.world_size > 1 and torch.distributed.is_initialized():
        picks = [None] * trainer.world_size
        torch.distributed.all_gather_object(picks, ours)
    if len(set(picks)) > 1:
        detail = "; ".join(f"rank {rank}: {pick}" for rank, pick in enumerate(picks))
        raise RuntimeError(f"the processes picked different best checkpoints ({detail}): validation metrics "
                           "must be averaged over all processes (self.log(..., sync_dist=True))")
    return ours


def fit(job: Job) -> Fitted:
    """Train within the budget (mcd.lit.budget), keep the best validation checkpoint, and say what to test;
    a method that is not trained (``method.trainable=false``, a transfer without fine-tuning) is tested as
    built."""
    from mcd.lit import budget

    trainer = job.trainer
    t0 = time.perf_counter()
    if not job.trainable:
        if job.transfer is not None:
            log.info("testing the weights loaded from %s as they are (transfer.finetune_epochs=0)",
                     job.transfer["init_from"])
        else:
            log.info("method %s is not trained (method.trainable=false): testing it as built",
                     job.cfg.method.name)
        return Fitted(checkpoint=None, best_val_psnr=None, stop_reason="not trained",
                      seconds=time.perf_counter() - t0, segments=[])
    if trainer.strategy.root_device.type == "cpu":
        from mcd.core.cpu_threads import fit_to_load

        fit_to_load()  # fewer threads beside other CPU-bound jobs, unless OMP_NUM_THREADS chose
    with warnings.catch_warnings():
        # Two of Lightning's warnings that do not apply here: metrics are logged every log_every_n_steps
        # optimiser steps counted over epochs, so an epoch shorter than that interval still logs; and a run
        # resumed from a last.ckpt written mid-epoch (after a validation every train.val_every_steps) draws
        # fresh random crops for the rest of that epoch, which is all a resumable loader would give
        warnings.filterwarnings("ignore", message=r".*smaller than the logging interval")
        warnings.filterwarnings("ignore", message=r".*resuming from a checkpoint that ended before the epoch")
        trainer.fit(job.module, datamodule=job.datamodule, ckpt_path=job.resume, weights_only=True)
    budget.finish(trainer, job.module, job.datamodule, job.best, job.curve)
    path, score = agreed_best(trainer, job.best)
    tested = path or str(job.out_dir / "checkpoints" / "last.ckpt")
    if not Path(tested).is_file() and job.resume:  # resumed at or past its budget: no step, no checkpoint
        tested = job.resume
    log.info("testing checkpoint %s (best val/psnr %s)", tested,
             "none" if score is None else f"{score:.2f} dB")
    seconds = time.perf_counter() - t0
    # read now: testing a checkpoint restores the callbacks' state saved in it, this one's included
    return Fitted(checkpoint=tested, best_val_psnr=score,
                  stop_reason=budget.stop_reason(trainer, job.cfg.train, seconds), seconds=seconds,
                  segments=job.segments.records())


def run_test(job: Job, checkpoint: str | None) -> float:
    """Test ``checkpoint`` (None: the model as it is) on whole sequences; the recorder writes ``frames.csv``
    and ``samples/`` and keeps the averages (rank 0). Returns the seconds it took."""
    t0 = time.perf_counter()
    job.trainer.test(job.module, datamodule=job.datamodule, ckpt_path=checkpoint, verbose=False,
                     weights_only=True)
    return time.perf_counter() - t0


def run_record(job: Job, fitted: Fitted, test_s: float, choices: dict[str, str], code: dict[str, object],
               started: float) -> RunRecord:
    """The :class:`~mcd.lit.run_record.RunRecord` of a tested job (rank 0: it holds the test's averages)."""
    import torch

    from mcd.models.complexity import complexity, count_params

    cfg, model, trainer, averages = job.cfg, job.model, job.trainer, job.recorder.averages
    assert averages is not None, "run_record needs the test's averages (global rank 0, after test)"
    replaced = job.datamodule.replaced_by_0()  # counted in the record (docs/reliability.md, campaign 8)
    if replaced["values"]:
        log.warning("%d NaN/Inf/negative value(s) in %d file(s) of this run's data were replaced by 0 (%s); "
                    "metrics.json counts them under data.replaced_by_0", replaced["values"],
                    replaced["files"], ", ".join(f"{b} {n}" for b, n in replaced["by_buffer"].items()))
    params_m = count_params(model) / 1e6
    try:
        macs_g: float | None = complexity(cfg)[1]
    except (NotImplementedError, RuntimeError) as err:
        macs_g = None
        log.warning("MACs of %s not counted (%s: %s): macs_g is null", cfg.method.name,
                    type(err).__name__, err)
    return RunRecord(
        scores=RunRecord.scores_of(averages),
        macs_g=macs_g,
        params_m=params_m,
        experiment=str(cfg.experiment),
        method=OmegaConf.to_container(cfg.method, resolve=True),  # type: ignore[arg-type]
        switches=switch_row(cfg.method) if cfg.method.name in SWITCHED_METHODS else None,
        budget=int(cfg.budget),
        seed=int(cfg.seed),
        data_profile=choices.get("data"),
        capacity_profile=choices.get("capacity"),
        train_profile=choices.get("train"),
        data_settings=job.data_settings,
        per_scene=averages["per_scene"],  # type: ignore[arg-type]
        scenes_test=list(averages["frames"]),  # type: ignore[call-overload]
        test_frames=averages["frames"],  # type: ignore[arg-type]
        perceptual_loss=job.module.loss_fn.perceptual_status.as_dict(),
        commit=str(code["commit"]),
        dirty=code["dirty"],  # type: ignore[arg-type]
        device=device_name(job.module.device),
        precision=job.precision,
        torch=torch.__version__,
        allocator=allocator.policy(),
        config=str(job.out_dir / "resolved_config.yaml"),
        data={**job.data_report, "replaced_by_0": replaced},
        trained=job.trainable,
        transfer=job.transfer,
        checkpoint=fitted.checkpoint,
        best_val_psnr=fitted.best_val_psnr,
        train_steps=int(trainer.global_step),
        stop_reason=fitted.stop_reason,
        segments=fitted.segments,
        epochs=int(trainer.current_epoch),
        data_s=job.data_s,
        train_s=fitted.seconds,
        test_s=test_s,
        wall_s=time.perf_counter() - started,
    )


def train_and_test(cfg: DictConfig, out_dir: Path, choices: dict[str, str],
                   started: float) -> dict[str, object] | None:
    """The whole run: build, fit, test, and (global rank 0) write ``metrics.json``; returns what it wrote
    (None on the other ranks of a DDP run)."""
    code = git_commit()  # the commit of the code this process imported (a sweep's first job asks first)
    job = build(cfg, out_dir, choices)
    fitted = fit(job)
    test_s = run_test(job, fitted.checkpoint)
    if not job.trainer.is_global_zero:
        return None
    metrics = run_record(job, fitted, test_s, choices, code, started).write(out_dir)
    (out_dir / "error.json").unlink(missing_ok=True)  # a retried job that failed before
    log.info("%s: PSNR %.2f dB (noisy %.2f), SSIM %.4f, rMSE %.4g, L_t %.4g, %.1f GMACs, %.3f M params, "
             "%.0f s -> %s",
             job.cfg.experiment, metrics["psnr"], metrics["input_psnr"], metrics["ssim"], metrics["rmse"],
             metrics["lt"] or math.nan, metrics["macs_g"] or math.nan,
             math.nan if metrics["params_m"] is None else metrics["params_m"], metrics["wall_s"], out_dir)
    train = OmegaConf.to_container(job.cfg.train, resolve=True)
    log.info("%s", summary(metrics, out_dir, train))  # type: ignore[arg-type]  # the last thing printed
    return metrics


def _skip_finished(out_dir: Path, cfg: DictConfig, choices: dict[str, str]) -> bool:
    """True (logged) if ``out_dir`` holds a finished run of this job; FileExistsError naming the keys if it
    holds another job's finished run; False if it holds none."""
    if not is_complete(out_dir / "metrics.json"):
        return False
    check_same_job(out_dir / "metrics.json", cfg, choices)
    log.info("skip: %s already holds a complete metrics.json", out_dir)
    return True


#: What a run writes in its directory, and the records that make a folder a run's (mcd.config.compose
#: check_unclaimed: a folder holding the first and none of the second is a user's, refused before any write)
RUN_OUTPUTS = ("resolved_config.yaml", "curve.csv", "frames.csv", "metrics.json", "error.json", "logs", "tb",
               "samples", "checkpoints", "run.log")
RUN_RECORDS = (".hydra", "job.json", run_dir.LOCK_NAME)


# a sweep's job with a bad value writes its error.json (build's preflight)
@hydra_main(job_errors=True, run_files=(RUN_OUTPUTS, RUN_RECORDS))
def main(cfg: DictConfig) -> None:
    """Hydra entry point (see the module docstring)."""
    from lightning.pytorch.utilities import rank_zero_only

    started = time.perf_counter()
    allocator.keep_freed_memory()  # training steps and full test frames reuse freed pages (core/allocator)
    hydra_cfg = HydraConfig.get()
    out_dir = Path(hydra_cfg.runtime.output_dir)
    choices = dict(hydra_cfg.runtime.choices)
    # a finished run is never written again (mcd/lit/run_dir.py): skipped, or refused when it is another
    # job's, before the lock is taken and outside the try (no error.json); Hydra wrote nothing there either
    if _skip_finished(out_dir, cfg, choices):
        return
    # a link where the run writes (a sweep's job: a single run was checked before Hydra wrote anything)
    links.check_links("hydra.runtime.output_dir", out_dir, (*RUN_OUTPUTS, *RUN_RECORDS))
    # one owner per run directory (mcd/lit/run_dir.py): a second process is refused here, before it touches
    # the directory (no error.json either: the directory is the owner's); DDP's other ranks share rank 0's
    owner = run_dir.hold(out_dir) if rank_zero_only.rank == 0 else contextlib.nullcontext()
    with owner:
        if _skip_finished(out_dir, cfg, choices):  # it finished while this process started
            return
        try:
            train_and_test(cfg, out_dir, choices, started)
        except Exception as err:
            path = write_error(out_dir, cfg, list(hydra_cfg.overrides.task), err)
            if hydra_cfg.mode != RunMode.MULTIRUN:
                raise
            log.error("job failed (%s: %s); details in %s; the sweep goes on", type(err).__name__, err, path)


if __name__ == "__main__":
    main()

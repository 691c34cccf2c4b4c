"""``python -m mcd.run +experiment=F``: render (or load) the data, train, keep the best validation checkpoint,
test it on whole sequences, and write the run directory (docs/architecture.md, "Run directory").

Overrides: ``paths.data_dir=<dir>``, ``hydra.run.dir=<dir>``, ``ckpt_path=<file>`` (resume training from a
checkpoint), ``trainer.precision=bf16-mixed`` (GPU), any ``train.*`` / ``data.*`` / ``method.*`` key.
Sweeps (``-m``): a job whose output directory already holds a complete ``metrics.json`` of the same job
(:func:`job_identity`) is skipped, one of another job is an error; a job that raises writes ``error.json``
(overrides, config, traceback) and the sweep goes on, then exits 1 naming the failed jobs
(``mcd.hydra_callbacks.FailedJobs``). A single run re-raises.
"""

from __future__ import annotations

import functools
import json
import logging
import math
import os
import platform
import subprocess
import time
import traceback
from pathlib import Path

import hydra
import lightning as L
import pandas as pd
import torch
from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from hydra.utils import instantiate
from lightning.pytorch.callbacks import ModelCheckpoint
from omegaconf import DictConfig, OmegaConf

from mcd.lit import DenoiseModule, budget, build_loss
from mcd.metrics import FRAME_METRICS, MODEL_METRICS, aggregate
from mcd.models.switches import check_switches, switch_row
from mcd.preflight import check_run

log = logging.getLogger("mcd.run")

#: Keys a finished run's ``metrics.json`` must hold (a sweep skips jobs that have them all).
REQUIRED_KEYS = ("psnr", "ssim", "rmse", "lt", "input_psnr", "input_ssim", "input_rmse", "macs_g", "params_m",
                 "experiment", "method", "budget", "data_profile", "commit", "device", "wall_s", "per_scene",
                 "perceptual_loss")
REPO = Path(__file__).resolve().parent.parent
#: Methods whose ``method.UN..SA`` switches mean something (the component study; ``unet`` is row A).
SWITCHED_METHODS = ("two_stage", "unet")


def is_complete(path: Path) -> bool:
    """Whether ``path`` is a readable ``metrics.json`` holding every key of :data:`REQUIRED_KEYS`."""
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return False
    return isinstance(data, dict) and all(k in data for k in REQUIRED_KEYS)


def job_identity(cfg: DictConfig, choices: dict[str, str]) -> dict[str, object]:
    """What makes two runs the same job: the values ``train_and_test`` records under these keys.

    Settings a rerun may change without making it another job (epochs, capacity, ...) are left out
    (sweeps/_sweep_dirs.yaml: such a rerun goes to another ``sweep_tag``).
    """
    return {"experiment": str(cfg.experiment), "budget": int(cfg.budget), "seed": int(cfg.seed),
            "data_profile": choices.get("data"),
            "switches": switch_row(cfg.method) if cfg.method.name in SWITCHED_METHODS else None}


def check_same_job(path: Path, cfg: DictConfig, choices: dict[str, str]) -> None:
    """FileExistsError if the finished ``metrics.json`` at ``path`` is another job's (it is not skipped)."""
    done = json.loads(path.read_text())
    differs = {k: (done[k], v) for k, v in job_identity(cfg, choices).items() if k in done and done[k] != v}
    if differs:
        detail = "; ".join(f"{k}: {old!r} there, {new!r} here" for k, (old, new) in differs.items())
        raise FileExistsError(f"{path.parent} holds a finished run of another job ({detail}); give this run "
                              "its own directory (hydra.run.dir=<dir>, or sweep_tag=<tag> in a sweep)")


@functools.cache
def git_commit() -> dict[str, object]:
    """The repository's commit and whether its working tree differs from it ("unknown" outside git), as
    first asked in this process: a sweep's jobs all run the code imported when it started, so later commits
    must not be recorded as theirs (``train_and_test`` asks before anything else)."""
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO, capture_output=True, text=True,
                                check=True).stdout.strip()
        status = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=REPO,
                                capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return {"commit": "unknown", "dirty": None}
    return {"commit": commit, "dirty": bool(status.strip())}


def device_name(device: torch.device) -> str:
    """GPU name, or the CPU model and the threads torch uses."""
    if device.type == "cuda":
        return torch.cuda.get_device_name(device)
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"CPU {model} ({torch.get_num_threads()} threads, {os.cpu_count()} cores)"


def write_error(out_dir: Path, cfg: DictConfig, overrides: list[str], err: BaseException) -> Path:
    """``error.json``: the job's overrides, its config and the traceback."""
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "error.json"
    path.write_text(json.dumps({
        "error": f"{type(err).__name__}: {err}",
        "overrides": overrides,
        "config": OmegaConf.to_container(cfg, resolve=False),
        "traceback": traceback.format_exception(err),
    }, indent=2))
    return path


def _json_safe(value: object) -> object:
    """NaN/inf become ``None`` (JSON has no NaN)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    return value


def train_and_test(cfg: DictConfig, out_dir: Path, choices: dict[str, str],
                   started: float) -> dict[str, object]:
    """The whole run; returns what it wrote to ``metrics.json``."""
    from mcd.complexity import complexity, count_params
    from mcd.data import MCDDataModule, Store
    from mcd.lit import checkpoint, transfer
    from mcd.models import build

    code = git_commit()  # the commit of the code this process imported (a sweep's first job asks first)
    if cfg.method.name in SWITCHED_METHODS:
        check_switches(cfg.method)
    check_run(cfg)  # budget and image size, before anything is rendered
    resume = cfg.get("ckpt_path")
    if resume and not Path(resume).is_file():
        raise FileNotFoundError(f"ckpt_path={resume}: no such checkpoint file "
                                "(give a run's checkpoints/last.ckpt)")
    L.seed_everything(int(cfg.seed), workers=True)
    cfg, transfer_info = transfer.prepare(cfg)  # held-out scenes from trained weights (mcd/lit/transfer.py)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "resolved_config.yaml").write_text(OmegaConf.to_yaml(cfg, resolve=True))

    model = build(cfg)
    if resume:  # read safely, and refuse another experiment's checkpoint before anything is rendered
        weights = checkpoint.model_weights(checkpoint.safe_load(resume, "ckpt_path"))
        checkpoint.check_fits(model, weights, "ckpt_path", resume)
    if transfer_info is not None:
        transfer.load_weights(model, transfer_info)
    buffers = set(model.required_buffers()) | {"ref", f"c{int(cfg.budget)}"}
    store = Store.from_cfg(cfg)
    t0 = time.perf_counter()
    report = store.ensure(buffers)  # logs one line: what was rendered, what was reused
    data_s = time.perf_counter() - t0
    datamodule = MCDDataModule(cfg, store, buffers, model.window)
    loss = build_loss(cfg)
    lit = DenoiseModule(cfg, model, loss, sample_dir=out_dir / "samples")

    best = ModelCheckpoint(dirpath=out_dir / "checkpoints", filename="best-step{step:06d}",
                           auto_insert_metric_name=False, monitor="val/psnr", mode="max", save_top_k=1)
    # last.ckpt after every validation, replacing the previous one (save_last on `best` would write it only
    # with a new best, so a killed run resumed from an older epoch); budget.finish rewrites it when it
    # validates once more where the budget ended
    last = ModelCheckpoint(dirpath=out_dir / "checkpoints", filename="last", save_top_k=1,
                           enable_version_counter=False)
    curve = budget.LearningCurve(out_dir / "curve.csv")
    trainer_cfg = budget.trainer_kwargs(cfg)
    trainer = L.Trainer(**trainer_cfg, default_root_dir=str(out_dir),
                        callbacks=[best, last, curve, *budget.callbacks(cfg.train)],
                        logger=instantiate(cfg.logger, save_dir=str(out_dir)))
    trainable = bool(cfg.method.get("trainable", True))
    trainable = trainable and (transfer_info is None or transfer_info["finetune"])  # 0 epochs: test as is
    if trainable and not any(p.requires_grad for p in model.parameters()):
        raise ValueError(f"method.name={cfg.method.name!r} has no trainable parameters: set "
                         "method.trainable=false to test it without training")
    t0 = time.perf_counter()
    if trainable:
        trainer.fit(lit, datamodule=datamodule, ckpt_path=resume or None, weights_only=True)
        budget.finish(trainer, lit, datamodule, best, curve)
        tested = best.best_model_path or str(out_dir / "checkpoints" / "last.ckpt")
        score = best.best_model_score
        log.info("testing checkpoint %s (best val/psnr %s)", tested,
                 "none" if score is None else f"{float(score):.2f} dB")
    else:
        tested = None
        if transfer_info is not None:
            log.info("testing the weights loaded from %s as they are (transfer.finetune_epochs=0)",
                     transfer_info["init_from"])
        else:
            log.info("method %s is not trained (method.trainable=false): testing it as built",
                     cfg.method.name)
    train_s = time.perf_counter() - t0
    stopped = budget.stop_reason(trainer, cfg.train, train_s) if trainable else "not trained"
    t0 = time.perf_counter()
    trainer.test(lit, datamodule=datamodule, ckpt_path=tested or None, verbose=False,
                 weights_only=True)
    test_s = time.perf_counter() - t0

    extra = [k for k in MODEL_METRICS if any(k in row for row in lit.test_rows)]
    rows = pd.DataFrame(lit.test_rows, columns=["scene", "frame", *FRAME_METRICS, *extra])
    rows.to_csv(out_dir / "frames.csv", index=False)
    averages = aggregate(lit.test_rows, (*FRAME_METRICS, *extra))
    # a network torch cannot see (OIDN) has unknown parameters, not zero
    params_m = count_params(model) / 1e6 if getattr(model, "macs_countable", True) else None
    try:
        macs_g: float | None = complexity(cfg)[1]
    except (NotImplementedError, RuntimeError) as err:
        macs_g = None
        log.warning("MACs of %s not counted (%s: %s): macs_g is null", cfg.method.name,
                    type(err).__name__, err)
    metrics = {
        **{k: averages[k] for k in FRAME_METRICS},
        **{k: averages.get(k) for k in MODEL_METRICS},
        "macs_g": macs_g,
        "params_m": params_m,
        "experiment": str(cfg.experiment),
        "method": OmegaConf.to_container(cfg.method, resolve=True),
        "switches": switch_row(cfg.method) if cfg.method.name in SWITCHED_METHODS else None,
        "budget": int(cfg.budget),
        "seed": int(cfg.seed),
        "data_profile": choices.get("data"),
        "model_profile": choices.get("model"),
        "train_profile": choices.get("train"),
        "per_scene": averages["per_scene"],
        "scenes_test": list(averages["frames"]),
        "test_frames": averages["frames"],
        "perceptual_loss": lit.loss_fn.perceptual_status.as_dict(),
        **code,
        "device": device_name(lit.device),
        "precision": str(trainer_cfg["precision"]),
        "torch": torch.__version__,
        "config": str(out_dir / "resolved_config.yaml"),
        "data": report,
        "trained": trainable,
        "transfer": transfer_info,
        "checkpoint": tested,
        "best_val_psnr": float(best.best_model_score) if best.best_model_score is not None else None,
        "train_steps": int(trainer.global_step),
        "stop_reason": stopped,
        "epochs": int(trainer.current_epoch),
        "data_s": data_s,
        "train_s": train_s,
        "test_s": test_s,
        "wall_s": time.perf_counter() - started,
    }
    metrics = _json_safe(metrics)
    (out_dir / "metrics.json").write_text(json.dumps(metrics, indent=2))
    (out_dir / "error.json").unlink(missing_ok=True)  # a retried job that failed before
    log.info("%s: PSNR %.2f dB (noisy %.2f), SSIM %.4f, rMSE %.4g, L_t %.4g, %.1f GMACs, %.3f M params, "
             "%.0f s -> %s",
             cfg.experiment, metrics["psnr"], metrics["input_psnr"], metrics["ssim"], metrics["rmse"],
             metrics["lt"] or math.nan, macs_g or math.nan, math.nan if params_m is None else params_m,
             metrics["wall_s"], out_dir)
    return metrics


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    """Hydra entry point (see the module docstring)."""
    started = time.perf_counter()
    hydra_cfg = HydraConfig.get()
    out_dir = Path(hydra_cfg.runtime.output_dir)
    choices = dict(hydra_cfg.runtime.choices)
    try:
        if is_complete(out_dir / "metrics.json"):
            check_same_job(out_dir / "metrics.json", cfg, choices)
            log.info("skip: %s already holds a complete metrics.json", out_dir)
            return
        train_and_test(cfg, out_dir, choices, started)
    except Exception as err:
        path = write_error(out_dir, cfg, list(hydra_cfg.overrides.task), err)
        if hydra_cfg.mode != RunMode.MULTIRUN:
            raise
        log.error("job failed (%s: %s); details in %s; the sweep goes on", type(err).__name__, err, path)


if __name__ == "__main__":
    main()

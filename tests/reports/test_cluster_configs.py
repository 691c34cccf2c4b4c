"""`trainer=ddp` and `hydra/launcher=slurm` compose with a sweep, and what they compose to is accepted by
Lightning and by hydra-submitit-launcher; the seeds sweep's job dirs."""

from __future__ import annotations

from pathlib import Path

import pytest
from hydra import compose, initialize_config_dir
from hydra.utils import get_class
from omegaconf import OmegaConf

from mcd.lit import budget, precision

CONF = Path(__file__).resolve().parents[2] / "conf"


def _compose(overrides: list[str]):
    with initialize_config_dir(config_dir=str(CONF), version_base="1.3"):
        return compose(config_name="config", overrides=overrides, return_hydra_config=True)


def test_ddp_trainer_composes_and_lightning_accepts_it():
    import lightning as L

    cfg = _compose(["+sweep=ablation", "trainer=ddp"])
    assert cfg.trainer.strategy == "ddp"
    assert cfg.trainer.accelerator == "gpu" and cfg.trainer.devices == -1 and cfg.trainer.num_nodes == 1
    # the default trainer's keys come along (ddp extends it); train.* owns the budget keys (one key each)
    assert cfg.trainer.log_every_n_steps == 10 and "limit_train_batches" not in cfg.trainer
    limits = budget.trainer_limits(cfg.train)
    assert (limits["limit_train_batches"], limits["gradient_clip_val"]) == (cfg.train.limit_train_batches,
                                                                           cfg.train.grad_clip)
    # Lightning takes every key; on this GPU-less machine, DDP over 2 CPU processes (nothing is launched here)
    kwargs = OmegaConf.to_container(cfg.trainer, resolve=True)
    kwargs.update(accelerator="cpu", devices=2, enable_progress_bar=False)
    kwargs["precision"] = precision.resolve(kwargs["precision"], "cpu")
    trainer = L.Trainer(
        **kwargs, **budget.trainer_limits(cfg.train), logger=False, enable_checkpointing=False
    )
    assert type(trainer.strategy).__name__ == "DDPStrategy"
    assert trainer.num_devices == 2


def test_slurm_launcher_composes_with_a_sweep_and_ddp():
    pytest.importorskip("hydra_plugins.hydra_submitit_launcher", reason="pip install 'mcd[cluster]'")
    cfg = _compose(
        [
            "+sweep=ablation",
            "trainer=ddp",
            "hydra/launcher=slurm",
            "hydra.launcher.gpus_per_node=4",
            "trainer.num_nodes=2",
            "hydra.launcher.partition=gpu",
        ]
    )
    launcher = cfg.hydra.launcher
    assert launcher._target_.endswith("SlurmLauncher")
    assert get_class(launcher._target_).__name__ == "SlurmLauncher"
    assert launcher.gpus_per_node == 4 and launcher.tasks_per_node == 4  # one task per GPU for Lightning
    assert launcher.nodes == 2 and launcher.partition == "gpu"
    raw = OmegaConf.to_container(cfg.hydra, resolve=False)
    assert raw["launcher"]["submitit_folder"].startswith("${hydra.sweep.dir}")
    # the sweep is the same as on one machine: 13 jobs, deterministic directories
    assert cfg.hydra.sweeper.params["+experiment"] == "A,B,C,D,E,F,G,H,I,J,K,L,M"
    assert raw["sweep"]["dir"] == "multirun/${sweep_name}/${hydra.runtime.choices.data}${sweep_tag}"
    assert raw["sweep"]["subdir"] == "${experiment}_spp${budget}"


def test_slurm_launcher_without_ddp_runs_one_gpu_jobs():
    pytest.importorskip("hydra_plugins.hydra_submitit_launcher", reason="pip install 'mcd[cluster]'")
    cfg = _compose(["+sweep=baselines", "hydra/launcher=slurm"])
    assert cfg.hydra.launcher.nodes == 1 and cfg.hydra.launcher.tasks_per_node == 1
    assert cfg.trainer.devices == 1


def test_seeds_sweep_names_each_job_by_its_seed():
    cfg = _compose(["+sweep=seeds", "+experiment=F", "seed=3"])
    raw = OmegaConf.to_container(cfg.hydra, resolve=False)
    assert raw["sweep"]["subdir"] == "${experiment}_spp${budget}_seed${seed}"
    assert cfg.hydra.sweeper.params["seed"] == "0,1,2,3,4" and cfg.seed == 3 and cfg.sweep_name == "seeds"


def test_a_trainer_key_that_train_owns_is_refused():
    """``train.limit_train_batches`` / ``train.grad_clip`` are the settings; the same key under ``trainer.*``
    would be a second place for it (mcd.lit.budget.trainer_kwargs)."""
    cfg = _compose(["+experiment=F", "+trainer.gradient_clip_val=1.0"])
    with pytest.raises(ValueError, match="trainer.gradient_clip_val is set by train.grad_clip"):
        budget.trainer_kwargs(cfg)

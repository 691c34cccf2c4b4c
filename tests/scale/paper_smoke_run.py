"""The training half of the paper-shaped smoke test (tests/scale/test_paper_smoke.py), one process per DDP
rank: ``python tests/scale/paper_smoke_run.py <data_dir> <out_dir> [override ...]``.

The parts ``mcd.run`` trains with, built as it builds them (mcd/run.py ``build``), on a synthetic 1920x1080
store that ``test_paper_smoke.py`` wrote: ``capacity=paper`` row F, the store packed into the training store
(every rank packs; the per-scene lock lets one do it), 256x256 crops from it with two loader workers, two DDP
processes on gloo (``trainer=ddp`` on CPU), two epochs of one clip per rank. The store has no render keys,
so the reader is a :class:`mcd.data.store.StoreReader` where ``mcd.run`` has a builder that would render it
again; that is the one step left out. Each rank writes what it saw to ``<out_dir>/rank<r>.json``, with each
step's wall-clock end (``seconds``, from the fit's start).

Further arguments are Hydra overrides applied after these: ``scripts/device_check.sh`` runs the same fit on a
GPU (``trainer.accelerator=gpu trainer.devices=1``: DDP on NCCL, bf16-mixed) and reads the step times.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import lightning as L
import torch

from mcd.config.compose import compose
from mcd.data import MCDDataModule, StoreReader
from mcd.data.buffers import run_buffers
from mcd.data.pack import pack
from mcd.data.synthetic_store import write_synthetic_store
from mcd.lit import DenoiseModule, budget
from mcd.losses import build_loss
from mcd.models import build

#: 7 frames: 1 test frame, 1 validation clip, 2 training clips of 2 frames (one per rank per epoch)
FRAMES = 7


def overrides(data_dir: str) -> list[str]:
    """The paper's model and trainer at paper shapes, on the synthetic scene ``synth``."""
    return ["+experiment=F", "capacity=paper", "data=tiny", "data.name=paper1080",
            f"paths.data_dir={data_dir}",
            "data.width=1920", "data.height=1080", "data.segments=1", f"data.frames_per_segment={FRAMES}",
            "data.test_fraction=0.143", "data.val_clips=1", "data.clip_len=2", "data.train_crop=256",
            "data.val_crop=256", "data.num_workers=2", "data.cache_in_memory=false",
            "+data.scenes.synth={kind: procedural, seed: 0}", "data.train_scenes=[synth]",
            "data.test_scenes=[synth]", "data.augment.reverse=false", "data.train_store.format=array",
            "trainer=ddp", "trainer.devices=2",
            "trainer.accelerator=cpu", "trainer.precision=32-true", "trainer.enable_progress_bar=false",
            "train.batch_size=1", "train.epochs=2", "train.max_steps=null", "train.max_minutes=null",
            "train.val_every=1", "train.val_every_steps=null", "train.sample_frames=[]"]


def write_store(data_dir: str, *extra: str) -> list[str]:
    """Writes the synthetic 1920x1080 store of :func:`overrides` (plus ``extra``) into ``data_dir``; returns
    the run's buffers (the store of the test and of ``scripts/device_check.sh``)."""
    cfg = compose([*overrides(data_dir), *extra])
    buffers = sorted(run_buffers(build(cfg).required_buffers(), cfg.budget))
    write_synthetic_store(data_dir, cfg.data, buffers)
    return buffers


class Seen(L.Callback):
    """Records each training batch's clip, shapes and loss on this rank; writes them when the fit ends."""

    def __init__(self, out: Path):
        self.out, self.steps, self.started = out, [], time.perf_counter()

    def on_fit_start(self, trainer, module):  # noqa: ANN001
        self.started = time.perf_counter()

    def on_train_batch_end(self, trainer, module, outputs, batch, batch_idx):  # noqa: ANN001
        loss = outputs["loss"] if isinstance(outputs, dict) else outputs
        self.steps.append({"epoch": trainer.current_epoch, "scene": batch["scene"][0],
                           "frames": batch["frame"][0].tolist(),
                           "shapes": {k: list(v.shape) for k, v in batch.items() if torch.is_tensor(v)},
                           "loss": float(loss), "seconds": time.perf_counter() - self.started})

    def on_fit_end(self, trainer, module):  # noqa: ANN001
        dm = trainer.datamodule
        loader = trainer.train_dataloader
        record = {"rank": trainer.global_rank, "world": trainer.world_size, "steps": self.steps,
                  "global_step": trainer.global_step, "num_workers": loader.num_workers,
                  "persistent_workers": loader.persistent_workers,
                  "reads_in_this_process": bool(dm.train_set.frames._maps),
                  "train_store": str(dm.train_store.root),
                  "finite_weights": all(math.isfinite(float(p.abs().sum())) for p in module.parameters())}
        (self.out / f"rank{trainer.global_rank}.json").write_text(json.dumps(record))


def main(data_dir: str, out_dir: str, *extra: str) -> None:
    cfg = compose([*overrides(data_dir), *extra])
    L.seed_everything(0, workers=True)
    model = build(cfg)
    buffers = run_buffers(model.required_buffers(), cfg.budget)
    reader = StoreReader.from_cfg(cfg, overrides=[])
    pack(cfg, reader, buffers)
    dm = MCDDataModule(cfg, reader, buffers, model.window)
    module = DenoiseModule(cfg, model, build_loss(cfg))
    trainer = L.Trainer(**budget.trainer_kwargs(cfg),
                        callbacks=[Seen(Path(out_dir)), *budget.callbacks(cfg.train)], logger=False,
                        enable_checkpointing=False, default_root_dir=out_dir)
    trainer.fit(module, datamodule=dm)


if __name__ == "__main__":
    main(*sys.argv[1:])

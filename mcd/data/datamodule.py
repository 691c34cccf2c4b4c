"""The LightningDataModule over the store (docs/architecture.md, "Batches"; docs/benchmark.md, "Data
protocol").

Splits per scene sequence (docs/benchmark.md: first 20% test, the rest train, 5-frame non-overlapping clips):
the first ``round(data.test_fraction * n)`` frames are the test sequence, the next ``data.val_clips`` clips of
``data.clip_len`` frames validate, the remaining frames give training clips, non-overlapping unless
``data.train_clip_stride`` is below ``clip_len`` (:func:`mcd.data.splits.split_of`). Training and
validation use ``data.train_scenes``; testing runs ``data.test_scenes`` (held-out transfer scenes among them)
on their whole test sequences.

- train: clips ``[B, T, C, h, w]`` with one random crop ``data.train_crop`` per clip (the same for all frames
  and buffers), batch ``train.batch_size``, shuffled; along each axis the crop lies against a frame edge
  (either one, equally) with probability ``data.train_crop_at_edge``, elsewhere uniformly (docs/training.md,
  "Crops at frame edges": uniform crops almost never hold the frame's outer pixels, which every test frame
  has); then the augmentations ``data.augment`` switches on (:mod:`mcd.data.augment`, docs/training.md,
  "Augmentations"; all off by default, as in the paper), one draw per clip;
- val: clips with a centre crop ``data.val_crop`` (the whole frame if it is smaller), batch 1;
- test: whole frames, one current frame per batch in sequence order, ``T = past + 1 + future`` of the model's
  ``window`` with the sequence's edge frames repeated, the current frame at index ``past``, and ``reset`` True
  on a sequence's first frame.

Under DDP (a trainer with ``world_size > 1``) the datamodule distributes the data itself (the run's trainer
has ``use_distributed_sampler=False``, mcd.lit.budget): training and validation clips are sharded across the
ranks by a ``DistributedSampler`` (as Lightning's own would: shuffled with ``seed`` for training, padded to
equal shares), and rank 0 tests every test frame, in order, while the other ranks test none: the test carries
temporal state along each whole sequence, so its frames cannot be split between processes.

Where clips come from (``data.train_store.format``): ``exr`` reads whole EXR frames and crops them
(:class:`mcd.data.clips.ExrClips`); ``array`` reads training and validation clips from the packed training
store, only the bytes a crop covers (:class:`mcd.data.train_store.TrainStore`, docs/training_store.md), after
checking at setup that every clip's frames are packed from today's EXR files. Test frames are whole frames and
always come from the EXR store. Memory maps open lazily in each loader worker; loaders pin memory when CUDA is
available.

The simulated adaptive render is built by the model from the stored ``c_{2^k}`` images, not here.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from typing import Any

import lightning as L
import torch
from omegaconf import DictConfig
from torch.utils.data import DataLoader, Dataset, DistributedSampler, Sampler, Subset

from mcd.data.augment import Augment
from mcd.data.buffers import BUFFERS, validate_buffers
from mcd.data.clips import ExrClips
from mcd.data.splits import check_crops, split_of
from mcd.data.store import StoreReader
from mcd.data.train_store import TrainStore, TrainStoreSettings, pack_command

log = logging.getLogger(__name__)


class ClipDataset(Dataset):
    """Training (random crop, then ``augment`` if given) or validation (centre crop) clips."""

    def __init__(
        self,
        frames: ExrClips | TrainStore,
        clips: list[tuple[str, list[int]]],
        crop: int,
        size: tuple[int, int],
        random_crop: bool,
        at_edge: float = 0.0,
        augment: Augment | None = None,
    ):
        self.frames, self.clips, self.random_crop = frames, clips, random_crop
        self.h, self.w = size
        self.ch, self.cw = min(crop, self.h), min(crop, self.w)
        self.at_edge, self.augment = at_edge, augment

    def __len__(self) -> int:
        return len(self.clips)

    def __getitem__(self, i: int) -> dict[str, Any]:
        scene, frames = self.clips[i]
        if self.random_crop:
            y, x = self._offset(self.h - self.ch), self._offset(self.w - self.cw)
        else:
            y, x = (self.h - self.ch) // 2, (self.w - self.cw) // 2
        clip = self.frames.clip(scene, frames, (y, x, self.ch, self.cw))
        return clip if self.augment is None else self.augment(clip)

    def _offset(self, last: int) -> int:
        """A random crop offset in ``0 .. last``: ``0`` or ``last`` (equally) with probability ``at_edge``,
        else uniform."""
        u = float(torch.rand(()).item())
        if u < self.at_edge:
            return 0 if u < self.at_edge / 2 else last
        return int(torch.randint(0, last + 1, ()).item())


class SequenceDataset(Dataset):
    """Whole test frames in sequence order, each with its window of neighbours and a ``reset`` flag."""

    def __init__(self, frames: ExrClips, sequences: list[tuple[str, list[int]]], window: tuple[int, int]):
        self.frames, self.window = frames, window
        self.items = [(scene, seq, i) for scene, seq in sequences for i in range(len(seq))]

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, i: int) -> dict[str, Any]:
        scene, seq, k = self.items[i]
        past, future = self.window
        idx = [seq[min(max(k + o, 0), len(seq) - 1)] for o in range(-past, future + 1)]
        out = self.frames.clip(scene, idx, None)
        out["reset"] = torch.tensor(k == 0)
        return out


class MCDDataModule(L.LightningDataModule):
    """Train / val / test loaders over the store for the buffers a model reads (plus ``ref``, always).

    `train_scenes` / `test_scenes` override ``data.train_scenes`` / ``data.test_scenes`` (e.g. fine-tuning on
    a held-out transfer scene). The buffers must have been rendered (``store.ensure``).
    """

    def __init__(
        self,
        cfg: DictConfig,
        store: StoreReader,
        buffers: Iterable[str],
        window: tuple[int, int] = (0, 0),
        train_scenes: list[str] | None = None,
        test_scenes: list[str] | None = None,
    ):
        super().__init__()
        self.cfg, self.store = cfg, store
        want = validate_buffers(buffers) | {"ref"}
        self.buffers = [b for b in BUFFERS if b in want]
        self.window = (int(window[0]), int(window[1]))
        d = cfg.data
        self.train_scenes = list(train_scenes if train_scenes is not None else d.train_scenes)
        self.test_scenes = list(test_scenes if test_scenes is not None else d.test_scenes)
        train_cfg = cfg.get("train") or {}
        self.batch_size = int(train_cfg.get("batch_size", 4))
        self.num_workers = int(d.get("num_workers", 0))
        self.seed = int(cfg.get("seed", 0))
        self._frames = ExrClips(store, self.buffers, bool(d.get("cache_in_memory", True)))
        self.train_store: TrainStore | None = None
        settings = TrainStoreSettings.from_cfg(cfg)
        if settings.format == "array":  # training and validation clips from the packed store
            self.train_store = TrainStore.open(settings, d, self.buffers,
                                               pack_command(store.overrides, self.buffers))
        self._ready = False
        self.frames_read: dict[str, list[int]] = {}  # scene: frames read (train, val, test)
        # under DDP the ranks other than 0 get an empty test loader (see the module docstring)
        self.allow_zero_length_dataloader_with_multiple_devices = True

    def setup(self, stage: str | None = None) -> None:
        if self._ready:
            return
        d = self.cfg.data
        h, w = int(d.height), int(d.width)
        check_crops(self.cfg)
        crop, at_edge = int(d.train_crop), float(d.get("train_crop_at_edge", 0.0))
        augment = Augment.from_cfg(d, buffers=self.buffers)
        train, val, test = [], [], []
        for scene in dict.fromkeys(self.train_scenes + self.test_scenes):
            sp = split_of(self.store.frame_count(scene), d)
            if scene in self.train_scenes:
                train += [(scene, c) for c in sp["train"]]
                val += [(scene, c) for c in sp["val"]]
            if scene in self.test_scenes:
                test += [(scene, s) for s in sp["test"]]
        self.frames_read = {scene: sorted({f for s, c in train + val + test if s == scene for f in c})
                            for scene in dict.fromkeys(self.train_scenes + self.test_scenes)}
        clips: ExrClips | TrainStore = self._frames
        if self.train_store is not None:
            for scene in self.train_scenes:  # every clip's frames packed from today's EXR files
                self.train_store.check_frames(scene, [f for s, c in train + val if s == scene for f in c],
                                              self.store.manifest(scene))
            clips = self.train_store
        self.train_set = ClipDataset(clips, train, crop, (h, w), random_crop=True, at_edge=at_edge,
                                     augment=augment)
        self.val_set = ClipDataset(clips, val, int(d.val_crop), (h, w), random_crop=False)
        self.test_set = SequenceDataset(self._frames, test, self.window)
        log.info(
            "datamodule %s: loading buffers %s; train %d clips of %d (crop %d, at a frame edge %.2f per "
            "axis; augmentations: %s) from %s (%s); "
            "val %d clips (crop %d); "
            "test %d frames from %s (window %s)",
            d.name,
            ",".join(self.buffers),
            len(train),
            int(d.clip_len),
            crop,
            at_edge,
            "none" if augment is None else augment.describe(),
            ",".join(self.train_scenes),
            "EXR" if self.train_store is None else f"training store {self.train_store.root}",
            len(val),
            min(int(d.val_crop), h, w),
            len(self.test_set),
            ",".join(self.test_scenes),
            self.window,
        )
        self._ready = True

    def replaced_by_0(self) -> dict[str, Any]:
        """The NaN/Inf/negative values replaced by 0 in the frames this datamodule reads (after
        :meth:`setup`; :meth:`mcd.data.store.StoreReader.replaced_counts`), for the run's ``metrics.json``."""
        return self.store.replaced_counts(self.frames_read, self.buffers)

    def _ranks(self) -> tuple[int, int]:
        """``(global rank, world size)`` of the trainer this datamodule serves; ``(0, 1)`` without one."""
        trainer = self.trainer
        return (int(trainer.global_rank), int(trainer.world_size)) if trainer is not None else (0, 1)

    def _loader(self, ds: Dataset, batch: int, shuffle: bool) -> DataLoader:
        rank, world = self._ranks()
        sampler: Sampler | None = None
        if world > 1:
            sampler = DistributedSampler(ds, num_replicas=world, rank=rank, shuffle=shuffle, seed=self.seed)
        return DataLoader(
            ds,
            batch_size=batch,
            shuffle=shuffle and sampler is None,
            sampler=sampler,
            num_workers=self.num_workers,
            drop_last=False,
            persistent_workers=self.num_workers > 0,
            pin_memory=torch.cuda.is_available(),
        )

    def train_dataloader(self) -> DataLoader:
        self.setup()
        return self._loader(self.train_set, self.batch_size, shuffle=True)

    def val_dataloader(self) -> DataLoader:
        self.setup()
        return self._loader(self.val_set, 1, shuffle=False)

    def test_dataloader(self) -> DataLoader:
        """Every test frame in sequence order on rank 0, none on the other ranks (module docstring)."""
        self.setup()
        rank, _ = self._ranks()
        frames = self.test_set if rank == 0 else Subset(self.test_set, [])
        return DataLoader(frames, batch_size=1, shuffle=False, num_workers=self.num_workers,
                          persistent_workers=self.num_workers > 0, pin_memory=torch.cuda.is_available())

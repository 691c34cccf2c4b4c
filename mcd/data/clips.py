"""Clips from the EXR store: the crop of a clip after whole-frame reads (docs/architecture.md, "Batches").

:class:`ExrClips` and :class:`mcd.data.train_store.TrainStore` give the same ``clip(scene, frames, crop)``
(docs/training_store.md): the datamodule reads training and validation clips through either
(``data.train_store.format``), and test frames through this one. This module does not import Lightning, so
``mcd.data.loader_rate`` measures the very read the datamodule does.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from mcd.data.store import StoreReader


class ExrClips:
    """Loads ``(scene, frame, buffer)`` as CHW float32 tensors from the EXR store (each a whole-frame decode
    through :meth:`StoreReader.load`), optionally kept in memory (``data.cache_in_memory``)."""

    def __init__(self, store: StoreReader, buffers: list[str], cache: bool):
        self.store, self.buffers, self.cache = store, buffers, cache
        self._mem: dict[tuple[str, int, str], torch.Tensor] = {}

    def get(self, scene: str, frame: int, buffer: str) -> torch.Tensor:
        key = (scene, frame, buffer)
        if key in self._mem:
            return self._mem[key]
        t = torch.from_numpy(np.ascontiguousarray(self.store.load(scene, frame, buffer).transpose(2, 0, 1)))
        if self.cache:
            self._mem[key] = t
        return t

    def clip(self, scene: str, frames: list[int], crop: tuple[int, int, int, int] | None) -> dict[str, Any]:
        """``{buffer: float32 [T, C, h, w], "scene", "frame": LongTensor[T]}`` for the crop ``(y, x, h, w)``
        (None: whole frames)."""
        out: dict[str, Any] = {}
        for b in self.buffers:
            ts = [self.get(scene, f, b) for f in frames]
            if crop is not None:
                y, x, h, w = crop
                ts = [t[:, y : y + h, x : x + w] for t in ts]
            out[b] = torch.stack(ts)
        out["scene"] = scene
        out["frame"] = torch.tensor(frames, dtype=torch.long)
        return out

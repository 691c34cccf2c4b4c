"""The test recorder: per-frame metrics, samples and averages of a test (docs/architecture.md,
"Run directory").

:class:`TestRecorder` is a Lightning callback that reads what ``DenoiseModule.test_step`` returns for each
whole test frame (the model's outputs, the reference and the noisy uniform input at the same budget,
``c{budget}``) and records, on global rank 0 only (the datamodule gives every test frame to rank 0,
docs/architecture.md "Batches"):

- one row per frame of the metrics of ``mcd.core.metrics`` (docs/benchmark.md, "Metrics") for the output and
  for the noisy input (``input_*``); ``lt`` pairs each frame with the previous one of its sequence (NaN on a
  sequence's first frame), as do ``tpsnr`` and ``input_tpsnr``; with KP also the kernel map's identity
  share (``kp_identity``) and the standard deviation of its kernel index ``h[0]`` over the frame's pixels
  (``kp_index_std``; 0 = one kernel everywhere); with a sampling map its spread (``map_spread``, standard
  deviation over mean) and its outer ring's share of the samples over the ring's share of the pixels
  (``map_ring_share``; :func:`mcd.core.metrics.map_spread`, :func:`mcd.core.metrics.map_ring_share`);
- ``samples/<scene>/`` (``mcd.lit.samples``) of the frames at the sequence positions ``train.sample_frames``;
- at the end of the test ``frames.csv`` (the rows) and :attr:`TestRecorder.averages`
  (``mcd.core.metrics.aggregate``: per scene, then over scenes) for the run record (``mcd.lit.run_record``).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path

import lightning as L
import numpy as np
import pandas as pd
from lightning.pytorch.callbacks import Callback
from torch import Tensor

from mcd.core.metrics import (
    FRAME_METRICS,
    MODEL_METRICS,
    aggregate,
    frame_metrics,
    map_ring_share,
    map_spread,
    temporal_l1,
    temporal_psnr,
)
from mcd.lit.samples import save_samples
from mcd.models.kernel_pool import identity_weight


def hwc(x: Tensor) -> np.ndarray:
    """``[C, H, W]`` tensor -> ``H x W x C`` float32 NumPy array."""
    return x.detach().float().permute(1, 2, 0).cpu().numpy()


def kernel_map_identity_share(kernel_map: Tensor) -> float:
    """Mean weight of the identity kernel, ``(h[1] + 1) / 2``, over a frame (paper Sec. 4.1, kernel
    interpolation): 1 means ``i_bar == i`` (the kernel pool unused), 0 means pool kernels only."""
    return float(identity_weight(kernel_map).mean())


class TestRecorder(Callback):
    """Records a test's frames (see the module docstring); ``run_dir=None`` keeps the rows in memory only."""

    __test__ = False  # not a pytest class

    def __init__(self, run_dir: str | Path | None = None, sample_frames: Iterable[int] = ()) -> None:
        self.run_dir = Path(run_dir) if run_dir is not None else None
        self.sample_frames = {int(i) for i in sample_frames}
        self.rows: list[dict[str, object]] = []
        #: ``mcd.core.metrics.aggregate`` of :attr:`rows` over :attr:`metric_keys`, set at the end of a test.
        self.averages: dict[str, object] | None = None
        self._prev: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # output, reference, input
        self._position = 0

    @property
    def metric_keys(self) -> tuple[str, ...]:
        """The metric columns of :attr:`rows`: ``FRAME_METRICS`` and the ``MODEL_METRICS`` a model has."""
        return (*FRAME_METRICS, *(k for k in MODEL_METRICS if any(k in row for row in self.rows)))

    def on_test_start(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        self.rows, self.averages, self._prev, self._position = [], None, None, 0

    def on_test_batch_end(self, trainer: L.Trainer, pl_module: L.LightningModule, outputs: object,
                          batch: object, batch_idx: int, dataloader_idx: int = 0) -> None:
        if trainer.is_global_zero:
            self.record(outputs)  # type: ignore[arg-type]

    def record(self, step: dict[str, object]) -> None:
        """Add one frame: ``step`` is what ``DenoiseModule.test_step`` returned for it."""
        out: dict[str, Tensor] = step["outputs"]  # type: ignore[assignment]
        if step["reset"]:
            self._prev, self._position = None, 0
        pred, ref, noisy = hwc(out["output"][0]), hwc(step["ref"]), hwc(step["noisy"])  # type: ignore[arg-type]
        scene, frame = str(step["scene"]), int(step["frame"])  # type: ignore[call-overload]
        row: dict[str, object] = {"scene": scene, "frame": frame, **frame_metrics(pred, ref),
                                  **frame_metrics(noisy, ref, prefix="input_")}
        if self._prev is None:
            row.update(lt=math.nan, tpsnr=math.nan, input_tpsnr=math.nan)
        else:
            prev, prev_ref, prev_noisy = self._prev
            row.update(lt=temporal_l1(pred, prev, ref, prev_ref),
                       tpsnr=temporal_psnr(pred, prev, ref, prev_ref),
                       input_tpsnr=temporal_psnr(noisy, prev_noisy, ref, prev_ref))
        if "kernel_map" in out:
            row["kp_identity"] = kernel_map_identity_share(out["kernel_map"])
            row["kp_index_std"] = float(out["kernel_map"][0, 0].float().std())
        if "sampling_map" in out:
            m = out["sampling_map"][0, 0].float().cpu().numpy()
            row["map_spread"], row["map_ring_share"] = map_spread(m), map_ring_share(m)
        self.rows.append(row)
        self._prev = (pred, ref, noisy)
        if self.run_dir is not None and self._position in self.sample_frames:
            images = {k: hwc(v[0]) for k, v in out.items() if isinstance(v, Tensor) and v.ndim == 4}
            images.update(noisy=noisy, reference=ref)
            save_samples(self.run_dir / "samples" / scene, frame, images)
        self._position += 1

    def on_test_end(self, trainer: L.Trainer, pl_module: L.LightningModule) -> None:
        if not trainer.is_global_zero:
            return
        keys = self.metric_keys
        self.averages = aggregate(self.rows, keys)
        if self.run_dir is not None:
            frames = pd.DataFrame(self.rows, columns=["scene", "frame", *keys])
            frames.to_csv(self.run_dir / "frames.csv", index=False)

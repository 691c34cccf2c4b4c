"""Timing one frame through a model (docs/benchmark.md "Metrics", speed): the inputs in the model's layout,
timed calls closed by a device synchronisation, and :func:`alternated_ms`, the median time of one output frame
of each of several built models at a given resolution (:class:`FrameTimer`), the models timed in turn.
``python -m mcd.bench`` (mcd/bench/speed.py) measures every inference path with these; the report's
speed-against-error figure (mcd/reporting/speed.py) measures each run's own model with :func:`alternated_ms`,
so that a point's latency and error come from one architecture, capacity and resolution, and the points'
times from the same rounds."""

from __future__ import annotations

import statistics
import time
from collections.abc import Callable

import numpy as np
import torch
from torch import Tensor, nn


def sync(device: torch.device) -> None:
    """Wait for the device's queued work (CUDA); nothing on CPU."""
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def model_inputs(
    model: nn.Module, buffers: dict[str, np.ndarray], device: torch.device, channels_last: bool
) -> dict[str, Tensor | None]:
    """One frame's inputs in the model's layout (`[1, C, H, W]`, or `[1, T, C, H, W]` for a window)."""
    past, future = getattr(model, "window", (0, 0))
    x: dict[str, Tensor | None] = {"ref": None}
    for name in model.required_buffers():
        if name == "ref":
            continue
        t = torch.from_numpy(np.ascontiguousarray(buffers[name])).permute(2, 0, 1)[None].to(device)
        if (past, future) != (0, 0):
            t = t[:, None].expand(-1, past + 1 + future, -1, -1, -1).contiguous()
        elif channels_last:
            t = t.contiguous(memory_format=torch.channels_last)
        x[name] = t
    return x


def time_calls(call: Callable[[], object], device: torch.device, warmup: int, reps: int) -> list[float]:
    """Milliseconds of `reps` calls after `warmup` calls, each closed by a device synchronisation."""
    for _ in range(warmup):
        call()
    sync(device)
    times = []
    for _ in range(reps):
        t0 = time.perf_counter()
        call()
        sync(device)
        times.append((time.perf_counter() - t0) * 1e3)
    return times


class FrameTimer:
    """One model prepared for timed frames on the CPU: fp32, eager, contiguous, batch 1, under
    ``torch.inference_mode``, on seeded synthetic buffers (:func:`mcd.data.synthetic.synthetic_frame`) at
    ``height`` x ``width``; a temporal model keeps its state from call to call after one ``reset()``, so its
    frames are timed in steady state."""

    def __init__(self, model: nn.Module, height: int, width: int) -> None:
        from mcd.data.synthetic import synthetic_frame

        self.device = torch.device("cpu")
        self.model = model.to(self.device).eval()
        self.size = (height, width)
        names = set(self.model.required_buffers()) - {"ref"}
        fake = synthetic_frame(names, height, width, lead=(), motion_px=2.0)
        self.inputs = model_inputs(self.model, {n: t.permute(1, 2, 0).numpy() for n, t in fake.items()},
                                   self.device, False)
        self.output: dict[str, Tensor] | None = None
        if hasattr(self.model, "reset"):
            self.model.reset()

    def call(self) -> None:
        """One output frame."""
        with torch.inference_mode():
            self.output = self.model(self.inputs)

    def timed(self) -> float:
        """Milliseconds of one output frame (:func:`time_calls`, no warm-up)."""
        return time_calls(self.call, self.device, 0, 1)[0]

    def check(self) -> None:
        """Raise where the last output frame is not finite."""
        if self.output is None or not torch.isfinite(self.output["output"].float()).all():
            height, width = self.size
            raise FloatingPointError(f"non-finite output of {type(self.model).__name__} at {width}x{height}")


def alternated_ms(timers: list[FrameTimer], warmup: int = 2, reps: int = 5) -> list[float | Exception]:
    """The median milliseconds of one output frame of each of ``timers``, timed in turn: after ``warmup``
    frames each, every one of ``reps`` rounds times one frame of every model, so that a change of the
    machine's load while they are timed falls on all of them alike (their times are compared with one
    another: the report's speed-against-error points). A model whose call raises, or whose last output is
    not finite, gets its exception in place of a time and leaves the later rounds."""
    results: list[float | Exception | None] = [None] * len(timers)
    times: list[list[float]] = [[] for _ in timers]

    def attempt(k: int, step: Callable[[], float | None]) -> float | None:
        try:
            return step()
        except Exception as err:  # one model that cannot run is its own row's reason, not the others' end
            results[k] = err
            return None

    for k, timer in enumerate(timers):
        for _ in range(warmup):
            if results[k] is None:
                attempt(k, timer.call)
    for _ in range(reps):
        for k, timer in enumerate(timers):
            ms = attempt(k, timer.timed) if results[k] is None else None
            if ms is not None:
                times[k].append(ms)
    for k, timer in enumerate(timers):
        if results[k] is None:
            attempt(k, timer.check)
    return [r if r is not None else statistics.median(t) for r, t in zip(results, times, strict=True)]


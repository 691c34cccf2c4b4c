"""Timing one frame through a model (docs/benchmark.md "Metrics", speed): the inputs in the model's layout,
timed calls closed by a device synchronisation, and :func:`latency_ms`, the median time of one output frame
of a built model at a given resolution. ``python -m mcd.bench`` (mcd/bench/speed.py) measures every inference
path with these; the report's speed-against-error figure (mcd/reporting/speed.py) measures each run's own
model with :func:`latency_ms`, so that a point's latency and error come from one architecture, capacity and
resolution."""

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


def latency_ms(model: nn.Module, height: int, width: int, warmup: int = 2, reps: int = 5) -> float:
    """Median milliseconds of one output frame of ``model`` at ``height`` x ``width`` on the CPU: fp32, eager,
    contiguous, batch 1, under ``torch.inference_mode``, in steady state (a temporal model keeps its state
    from call to call after one ``reset()``), on seeded synthetic buffers
    (:func:`mcd.data.synthetic.synthetic_frame`). Raises on a non-finite output."""
    from mcd.data.synthetic import synthetic_frame

    device = torch.device("cpu")
    model = model.to(device).eval()
    names = set(model.required_buffers()) - {"ref"}
    fake = synthetic_frame(names, height, width, lead=(), motion_px=2.0)
    x = model_inputs(model, {n: t.permute(1, 2, 0).numpy() for n, t in fake.items()}, device, False)
    out: list[dict[str, Tensor]] = []

    def call() -> None:
        with torch.inference_mode():
            out[:] = [model(x)]

    if hasattr(model, "reset"):
        model.reset()
    ms = statistics.median(time_calls(call, device, warmup, reps))
    if not torch.isfinite(out[0]["output"].float()).all():
        raise FloatingPointError(f"non-finite output of {type(model).__name__} at {width}x{height}")
    return ms

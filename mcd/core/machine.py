"""The machine a run or benchmark ran on, as every record names it (docs/benchmark.md, "Reports": each
figure names its machine): the GPU's name, or the CPU model with the threads torch uses and the cores. Also
the one reader of the process's memory figures (``/proc/self/status``: :func:`status_mb`, its peak restarted
by :func:`restart_peak_rss`) for the benchmarks and the plan (docs/scale.md)."""

from __future__ import annotations

import contextlib
import os
import platform
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import torch


def device_name(device: torch.device) -> str:
    """GPU name, or ``CPU <model> (<threads> threads, <cores> cores)``."""
    import torch  # on first use: importing this module stays fast (docs/architecture.md, "Start-up")

    if device.type == "cuda":
        return torch.cuda.get_device_name(device)
    model = platform.processor() or platform.machine()
    with contextlib.suppress(OSError):
        lines = Path("/proc/cpuinfo").read_text().splitlines()
        model = next((ln.split(":", 1)[1].strip() for ln in lines if ln.startswith("model name")), model)
    return f"CPU {model} ({torch.get_num_threads()} threads, {os.cpu_count()} cores)"


def status_mb(field: str) -> float:
    """A memory field of ``/proc/self/status`` (``VmRSS``, ``VmHWM``, ``RssAnon``, ...) in MB (2^20 bytes);
    NaN where the field is absent; OSError where there is no ``/proc`` (not Linux)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith(field + ":"):
            return int(line.split()[1]) / 1024
    return float("nan")


def restart_peak_rss() -> None:
    """Restart the process's peak resident memory (``VmHWM`` of :func:`status_mb`) from its current size
    (``/proc/self/clear_refs``; nothing where there is no ``/proc``): the peak of the work that follows."""
    with contextlib.suppress(OSError):
        Path("/proc/self/clear_refs").write_text("5")

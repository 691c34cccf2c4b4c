"""How many threads a CPU training uses on a busy machine (docs/training.md "CPU threads").

PyTorch's intra-op pool defaults to one thread per core, and every operation ends in a barrier where its
threads wait for each other. Beside another CPU-bound process a thread is often descheduled, so the others
spin at each barrier until it returns: a run on all cores beside a sweep is many times slower than the same
run on the cores that are free (docs/training.md "CPU threads" has the figures).

:func:`fit_to_load` runs before training when the user did not choose (``OMP_NUM_THREADS`` unset): it measures
for a moment how many cores other processes keep busy (``/proc/stat`` less this process's own time) and
lowers torch's thread count to the free cores, at least one, saying so in one log line. It never raises the
count, and does nothing where there is no ``/proc`` (not Linux).
"""

from __future__ import annotations

import logging
import os
import time
from pathlib import Path

log = logging.getLogger(__name__)

#: How long :func:`other_busy_cores` watches the machine, in seconds.
WATCH_S = 0.5


def _machine_ticks() -> tuple[int, int, int]:
    """(busy, total, cpus) from ``/proc/stat``: ticks summed over every CPU since boot, and the CPU count."""
    lines = Path("/proc/stat").read_text().splitlines()
    values = [int(v) for v in lines[0].split()[1:9]]  # user nice system idle iowait irq softirq steal
    cpus = sum(1 for ln in lines if ln.startswith("cpu") and ln[3:4].isdigit())
    idle = values[3] + values[4]
    return sum(values) - idle, sum(values), cpus


def _own_ticks() -> int:
    """User and system ticks of this process, all its threads (``/proc/self/stat`` fields 14 and 15)."""
    fields = Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])


def other_busy_cores(seconds: float = WATCH_S) -> float:
    """Cores that other processes kept busy over the next ``seconds``, on average (0 = an idle machine);
    OSError where there is no ``/proc``."""
    busy0, total0, cpus = _machine_ticks()
    own0 = _own_ticks()
    time.sleep(seconds)
    busy1, total1, _ = _machine_ticks()
    own1 = _own_ticks()
    elapsed = (total1 - total0) / max(cpus, 1)  # ticks of one CPU over the window
    if elapsed <= 0:
        return 0.0
    return max(0.0, (busy1 - busy0) - (own1 - own0)) / elapsed


def threads_for(default: int, cores: int, other_busy: float) -> int:
    """The thread count for ``cores`` usable cores of which ``other_busy`` (rounded) are taken by other
    processes: the free ones, at least 1, at most ``default`` (torch's own choice)."""
    return max(1, min(default, cores - round(other_busy)))


def fit_to_load() -> str | None:
    """Lower torch's intra-op threads to the cores other processes leave free (module docstring); the log
    line it wrote, or None when it changed nothing (``OMP_NUM_THREADS`` set, the machine free enough, or
    no ``/proc``)."""
    if os.environ.get("OMP_NUM_THREADS"):
        return None
    import torch

    try:
        other = other_busy_cores()
    except (OSError, ValueError, IndexError):
        return None
    cores = len(os.sched_getaffinity(0))
    default = torch.get_num_threads()
    threads = threads_for(default, cores, other)
    if threads >= default:
        return None
    torch.set_num_threads(threads)
    message = (f"the machine is busy (other processes keep {other:.1f} of {cores} cores busy): training "
               f"with {threads} thread(s) instead of {default}, since threads that wait on each other beside "
               f"other jobs slow a run far more than the lost cores (docs/training.md \"CPU threads\"); "
               f"set OMP_NUM_THREADS to choose")
    log.warning("%s", message)
    return message

"""A CPU training on a busy machine takes the free cores only (mcd/core/cpu_threads.py; docs/training.md "CPU
threads"): the measurement sees real busy processes, and the thread count follows it unless the user chose."""

import os
import subprocess
import sys

import pytest
import torch

from mcd.core import cpu_threads

BUSY_LOOP = "import time\nt = time.time() + 30\nwhile time.time() < t: pass\n"


@pytest.mark.parametrize(("default", "cores", "other", "want"), [
    (2, 2, 0.1, 2),    # idle: torch's own choice
    (2, 2, 0.7, 1),    # one core taken
    (2, 2, 2.0, 1),    # every core taken: still one thread
    (2, 2, 3.5, 1),
    (8, 16, 4.2, 8),   # never more than torch's choice
    (16, 16, 4.2, 12),
])
def test_threads_for_the_free_cores(default, cores, other, want):
    assert cpu_threads.threads_for(default, cores, other) == want


@pytest.fixture
def busy_cores():
    """One busy Python loop per usable core, stopped after the test."""
    procs = [subprocess.Popen([sys.executable, "-c", BUSY_LOOP]) for _ in os.sched_getaffinity(0)]
    try:
        yield len(procs)
    finally:
        for p in procs:
            p.kill()
            p.wait()


@pytest.fixture
def torch_threads():
    """torch's thread count, restored after the test."""
    before = torch.get_num_threads()
    yield
    torch.set_num_threads(before)


@pytest.mark.skipif(not os.path.exists("/proc/stat"), reason="needs Linux's /proc")
def test_other_processes_are_seen_and_this_one_is_not(busy_cores):
    """Each busy loop holds a core; this process's own work in the window is not counted."""
    other = cpu_threads.other_busy_cores(1.0)
    assert other > busy_cores - 0.6, other


@pytest.mark.skipif(not os.path.exists("/proc/stat"), reason="needs Linux's /proc")
def test_a_busy_machine_lowers_the_threads_unless_the_user_chose(busy_cores, torch_threads, monkeypatch):
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    torch.set_num_threads(2)
    assert cpu_threads.fit_to_load() is None and torch.get_num_threads() == 2  # the user's choice stands
    monkeypatch.delenv("OMP_NUM_THREADS")
    message = cpu_threads.fit_to_load()
    assert message is not None and "OMP_NUM_THREADS" in message, message
    assert torch.get_num_threads() == 1

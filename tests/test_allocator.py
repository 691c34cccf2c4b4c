"""mcd/core/allocator.py: with ``keep_freed_memory`` the full-frame tensors of later frames reuse the pages
earlier ones freed (no page faults); with glibc's default every frame faults all of its pages in again. Each
case runs in its own process, since the setting is process-wide."""

from __future__ import annotations

import platform
import subprocess
import sys

import pytest

from mcd.core import allocator

pytestmark = pytest.mark.skipif(platform.libc_ver()[0] != "glibc", reason="the setting is glibc's")

PROBE = """
import sys
from pathlib import Path
import torch
from mcd.core import allocator

def minor_faults():
    return int(Path("/proc/self/stat").read_text().rsplit(")", 1)[1].split()[7])

print(allocator.apply(sys.argv[1]))
faults = []
for _ in range(8):                        # a "frame": two full-frame tensors (133 MB each) made and freed
    before = minor_faults()
    x = torch.ones(1, 16, 1080, 1920)
    y = torch.relu(x * 2)
    total = float(y.sum())
    del x, y
    faults.append(minor_faults() - before)
print(" ".join(map(str, faults)), total)
"""


def probe(choice: str) -> tuple[str, list[int]]:
    """The allocator policy and the page faults of each of 8 frames in a fresh process."""
    out = subprocess.run([sys.executable, "-c", PROBE, choice], capture_output=True, text=True, check=True)
    policy, numbers = out.stdout.strip().splitlines()
    *faults, total = numbers.split()
    assert float(total) == 2 * 1080 * 1920 * 16
    return policy, [int(f) for f in faults]


@pytest.mark.slow
def test_keep_reuses_freed_pages_and_system_faults_them_in_every_frame():
    policy, system = probe("system")
    assert policy == allocator.SYSTEM
    pages = 2 * 1080 * 1920 * 16 * 4 // 4096
    assert min(system) > 0.9 * pages          # glibc's default unmaps each tensor: every page faulted again
    policy, keep = probe("keep")
    assert policy == allocator.KEEP
    # the heap grows over the first frames until the frame's tensors fit in freed chunks, then stops faulting
    # (the chunks torch asks for are 64-byte aligned, so reuse takes a few frames, not one)
    assert sum(keep[-3:]) < min(system), keep

"""Keep freed memory in the process, so full-frame tensors reuse pages instead of faulting in new ones
(docs/inference.md, "The allocator").

Full-frame inference allocates and frees tensors of 100-800 MB per layer (a 1920x1080 map of 16 fp32 channels
is 133 MB). glibc's ``malloc`` serves every block above its mmap threshold (32 MiB at most) with a fresh
``mmap`` and unmaps it on ``free``, so the kernel faults in and zeroes every page of every such tensor again
on its first write, a large share of a full frame's time (docs/inference.md measures it).
:func:`keep_freed_memory` has glibc serve large blocks from its heap and never trim the heap on its own
(``mallopt(M_MMAP_MAX, 0)`` and ``mallopt(M_TRIM_THRESHOLD, -1)``), so the next tensor reuses the pages the
last one freed; an explicit ``malloc_trim`` still hands them back (the bench does, between methods). The
process then holds on to its peak memory until it exits or trims. PyTorch's CPU performance guide recommends
preloading jemalloc or tcmalloc for the same reason; this needs neither.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import platform

#: ``mallopt`` parameters (glibc's ``malloc.h``).
M_TRIM_THRESHOLD = -1
M_MMAP_MAX = -4

#: ``--allocator`` choices: keep freed memory (:func:`keep_freed_memory`), or glibc's default.
CHOICES = ("keep", "system")
#: The allocator setting a process runs with, as records name it.
SYSTEM = "system"
KEEP = "glibc, freed memory kept (no mmap, no trim)"

_policy = SYSTEM


def keep_freed_memory() -> bool:
    """Have glibc keep freed memory for reuse (see the module docstring); False (nothing changed) where the C
    library is not glibc or refuses."""
    global _policy
    if platform.libc_ver()[0] != "glibc":
        return False
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:
        return False
    if libc.mallopt(M_MMAP_MAX, 0) != 1 or libc.mallopt(M_TRIM_THRESHOLD, -1) != 1:
        return False
    _policy = KEEP
    return True


def system_default() -> None:
    """Undo :func:`keep_freed_memory`: glibc's default limits (65536 mmapped blocks, a 128 KiB trim
    threshold), the freed memory handed back, :data:`SYSTEM` as the setting; for a process that ran a
    command's ``main`` and goes on (the test suite runs commands in its workers)."""
    global _policy
    with contextlib.suppress(OSError, AttributeError):
        libc = ctypes.CDLL("libc.so.6")
        libc.mallopt(M_MMAP_MAX, 65536)
        libc.mallopt(M_TRIM_THRESHOLD, 128 * 1024)
    hand_back()
    _policy = SYSTEM


def hand_back() -> None:
    """Hand the heap's freed memory back to the OS now (glibc ``malloc_trim``; nothing elsewhere), whatever
    the setting."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL("libc.so.6").malloc_trim(0)


def policy() -> str:
    """The setting this process runs with: :data:`KEEP` once :func:`keep_freed_memory` succeeded, else
    :data:`SYSTEM`."""
    return _policy


def add_option(parser: argparse.ArgumentParser) -> None:
    """``--allocator keep|system`` (default ``keep``) on a benchmark's command line."""
    parser.add_argument("--allocator", choices=CHOICES, default="keep",
                        help="keep: glibc keeps freed memory for reuse (mcd/core/allocator.py); "
                             "system: glibc's default")


def apply(choice: str) -> str:
    """Apply ``--allocator``'s ``choice``; returns :func:`policy` (``keep`` falls back to :data:`SYSTEM`
    where the C library is not glibc)."""
    if choice == "keep":
        keep_freed_memory()
    return policy()

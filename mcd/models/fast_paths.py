"""The switch between the inference fast paths and their reference formulations (docs/inference.md "Fast
paths").

A fast path computes the same function as its reference (fp32 within 1e-4 relative; under bf16 autocast
within 0.1 dB PSNR of fp32: ``tests/models/test_fast_paths.py``) and runs inside the model's own forward, so
training, ``mcd-denoise`` and the bench all take it. ``with reference():`` runs the reference formulations
instead, for the equivalence tests and for A/B measurements.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

_reference = False


def enabled() -> bool:
    """Whether the fast paths run (everywhere but inside :func:`reference`)."""
    return not _reference


@contextmanager
def reference() -> Iterator[None]:
    """Run the reference formulations inside this block."""
    global _reference
    outer, _reference = _reference, True
    try:
        yield
    finally:
        _reference = outer

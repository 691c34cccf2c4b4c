"""Benchmark data path: scenes, camera paths, Mitsuba rendering, the EXR store and the datamodule.

The store has one reader (:class:`StoreReader`: manifest, load, frame count) and a builder that renders
(:class:`StoreBuilder`); its buffers are one table, :mod:`mcd.data.buffers`.
See docs/architecture.md ("The store", "Batches"), docs/benchmark.md ("Data protocol"), docs/data.md and
docs/scenes.md.
Importing this package imports none of its modules: each name below is imported on first use, so that
``mcd.data.buffers`` and the other light modules load without the store's dependencies, Mitsuba (the variant
is chosen when something is first rendered) or Lightning (``MCDDataModule``); docs/architecture.md,
"Start-up".
"""

from importlib import import_module
from typing import Any

#: Where each exported name lives.
_EXPORTS = {"BUFFERS": "mcd.data.buffers", "CorruptEXRError": "mcd.data.exr",
            "MCDDataModule": "mcd.data.datamodule", "StoreBuilder": "mcd.data.store_builder",
            "StoreReader": "mcd.data.store"}

__all__ = sorted(_EXPORTS)


def __getattr__(name: str) -> Any:
    """The exported ``name`` from its module, imported on first use."""
    if name in _EXPORTS:
        return getattr(import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

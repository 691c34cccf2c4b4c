"""Benchmark data path: scenes, camera paths, Mitsuba rendering, the EXR store and the datamodule.

The store has one reader (:class:`StoreReader`: manifest, load, frame count) and a builder that renders
(:class:`StoreBuilder`, also exported as ``Store``); its buffers are one table, :mod:`mcd.data.buffers`.
See docs/architecture.md ("The store", "Batches"), docs/benchmark.md ("Data protocol"), docs/data.md and
docs/scenes.md.
Importing this package does not import Mitsuba (the variant is chosen when something is first rendered) nor
Lightning (``MCDDataModule`` is imported on first use), so the store and the loader-rate measurement
(``mcd.data.loader_rate``) load without them.
"""

from typing import Any

from mcd.data.buffers import BUFFERS
from mcd.data.exr import CorruptEXRError
from mcd.data.store import StoreReader
from mcd.data.store_builder import Store, StoreBuilder

__all__ = ["BUFFERS", "CorruptEXRError", "MCDDataModule", "Store", "StoreBuilder", "StoreReader"]


def __getattr__(name: str) -> Any:
    """``MCDDataModule`` on first use (it imports Lightning)."""
    if name == "MCDDataModule":
        from mcd.data.datamodule import MCDDataModule

        return MCDDataModule
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

"""Benchmark data path: scenes, camera paths, Mitsuba rendering, the EXR store and the datamodule.

See docs/architecture.md ("The store", "Batches"), docs/benchmark.md ("Data protocol"), docs/data.md and
docs/scenes.md.
Importing this package does not import Mitsuba; the variant is chosen when something is first rendered.
"""

from mcd.data.datamodule import MCDDataModule
from mcd.data.exr import CorruptEXRError
from mcd.data.store import BUFFERS, Store

__all__ = ["BUFFERS", "CorruptEXRError", "MCDDataModule", "Store"]

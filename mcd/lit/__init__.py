"""Training: the LightningModule, budgets, checkpoints, the test recorder (docs/training.md)."""

from mcd.lit.module import DenoiseModule

__all__ = ["DenoiseModule"]

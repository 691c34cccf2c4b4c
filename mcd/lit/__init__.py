"""Training: the LightningModule, budgets, checkpoints, the test recorder (docs/training.md).

``DenoiseModule`` is imported on first use, so that the light modules of this package (``precision``,
``checkpoint``) load without Lightning (docs/architecture.md, "Start-up").
"""

from typing import Any

__all__ = ["DenoiseModule"]


def __getattr__(name: str) -> Any:
    """``DenoiseModule`` on first use (it imports Lightning)."""
    if name == "DenoiseModule":
        from mcd.lit.module import DenoiseModule

        return DenoiseModule
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")

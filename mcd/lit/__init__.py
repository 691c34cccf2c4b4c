"""Training: the LightningModule and the loss registry (docs/method.md, "Losses")."""

from mcd.lit.losses import LOSSES, build_loss, register_loss
from mcd.lit.module import DenoiseModule

__all__ = ["LOSSES", "DenoiseModule", "build_loss", "register_loss"]

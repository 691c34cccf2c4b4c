"""Training: the LightningModule, the loss registry and the component switches (method.md)."""

from mcd.lit.losses import LOSSES, build_loss, register_loss
from mcd.lit.module import DenoiseModule
from mcd.lit.switches import SWITCHES, check_switches, switch_row

__all__ = ["LOSSES", "SWITCHES", "DenoiseModule", "build_loss", "check_switches", "register_loss",
           "switch_row"]

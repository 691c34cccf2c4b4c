"""Intel Open Image Denoise through ``pyoidn`` (docs/benchmark.md "Experiments"; docs/baselines.md "Choices
the papers leave open").

Pretrained, single frame, colour + albedo + normal, HDR mode: the reference a practitioner would reach for.
No parameters and no training (``method.trainable: false``); it reads the uniform render at the budget.
``pyoidn`` is the optional extra ``mcd[oidn]``; without it, building the method fails with the install
command."""

from __future__ import annotations

import importlib
from types import ModuleType

import numpy as np
import torch
from torch import Tensor, nn

from mcd.models.baselines.oidn_network import MODEL_OF_QUALITY, OIDNUNet
from mcd.models.baselines.uniform import uniform_key
from mcd.models.inputs import need
from mcd.models.registry import register

INSTALL = "pip install 'mcd[oidn]'  (or: pip install pyoidn)"


def import_pyoidn() -> ModuleType:
    """``pyoidn``, or an ImportError that says how to install it."""
    try:
        return importlib.import_module("pyoidn")
    except ImportError as err:
        raise ImportError(f"method 'oidn' needs the optional package pyoidn, which is not installed: "
                          f"{INSTALL}") from err


class OIDN(nn.Module):
    """OIDN's ``RT`` filter (``quality``: high/balanced/fast) on ``c{budget}`` with albedo and normal."""

    window = (0, 0)
    temporal_state = False  # single-frame

    def __init__(self, budget: int, quality: str = "high") -> None:
        super().__init__()
        if quality not in MODEL_OF_QUALITY:
            raise ValueError(f"method.quality={quality!r}: OIDN's quality is one of "
                             f"{sorted(MODEL_OF_QUALITY)}")
        self.pyoidn = import_pyoidn()
        self.key = uniform_key(budget, "oidn")
        self.quality = quality

    def network(self) -> OIDNUNet:
        """The shape of the network OIDN runs at this quality, on the ``meta`` device (no weights): what
        :mod:`mcd.models.complexity` counts (mcd/models/baselines/oidn_network.py)."""
        with torch.device("meta"):
            return OIDNUNet(MODEL_OF_QUALITY[self.quality])

    def network_params(self) -> int:
        """Parameters of OIDN's own network (trained by OIDN's authors, fixed here)."""
        return sum(p.numel() for p in self.network().parameters())

    def required_buffers(self) -> set[str]:
        return {self.key, "normal", "albedo"}

    def reset(self) -> None:
        """Stateless."""

    @staticmethod
    def _hwc(t: Tensor) -> np.ndarray:
        return np.ascontiguousarray(t.detach().float().permute(1, 2, 0).cpu().numpy())

    @torch.no_grad()
    def forward(self, x: dict[str, Tensor | None]) -> dict[str, Tensor]:
        noisy = need(x, self.key, "oidn")
        albedo = need(x, "albedo", "oidn").clamp(0, 1)
        normal = need(x, "normal", "oidn").clamp(-1, 1)
        if noisy.device.type == "meta":  # counting MACs (mcd.models.complexity): OIDN's network in shape only
            return {"output": self.network()(torch.cat((noisy, albedo, normal), 1))}
        out = [self.pyoidn.denoise(self._hwc(c.clamp_min(0)), albedo=self._hwc(a), normal=self._hwc(n),
                                   hdr=True, quality=self.quality)
               for c, a, n in zip(noisy, albedo, normal, strict=True)]
        return {"output": torch.from_numpy(np.stack(out)).permute(0, 3, 1, 2).to(noisy)}


#: Its catalogue entries (mcd.config.methods.Method's fields; read from this file without importing it,
#: docs/architecture.md "Methods").
ENTRIES = (
    {"experiment": "oidn", "display": "OIDN", "table1": True, "bench": True},
)


@register("oidn")
def build_oidn(*, budget: float, quality: str = "high") -> OIDN:
    """OIDN on ``c{budget}``; ``quality``: high / balanced / fast (conf/method/oidn.yaml)."""
    return OIDN(budget, str(quality))

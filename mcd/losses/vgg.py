"""VGG-16 feature extractor for the perceptual loss ``L_p`` (paper Sec. "Loss functions"; docs/method.md
"Losses").

torchvision is not a dependency: the feature layers of VGG-16 (Simonyan & Zisserman 2014, configuration "D")
are defined here with torchvision's module indices, so that a torchvision-format state dict
(``features.0.weight`` ... ``features.28.bias``, e.g. ``vgg16-397923af.pth``) loads as is. Weights come only
from a local file (``paths.vgg16_weights``); nothing is downloaded, and a randomly initialised network is
never used: without a file the perceptual term is off (see :func:`load_perceptual`).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import torch
from torch import Tensor, nn

log = logging.getLogger(__name__)

#: VGG-16 ("D"): output channels of each 3x3 conv, "M" a 2x2 max-pool.
VGG16_CFG: tuple[int | str, ...] = (64, 64, "M", 128, 128, "M", 256, 256, 256, "M", 512, 512, 512, "M",
                                    512, 512, 512, "M")
#: Indices in ``features`` of relu1_2, relu2_2, relu3_3, relu4_3 (Johnson et al. 2016's choices).
DEFAULT_LAYERS = (3, 8, 15, 22)
IMAGENET_MEAN = (0.485, 0.456, 0.406)
IMAGENET_STD = (0.229, 0.224, 0.225)


def vgg16_features() -> nn.Sequential:
    """VGG-16's convolutional part with torchvision's layer indices (conv, ReLU, ..., max-pool)."""
    layers: list[nn.Module] = []
    channels = 3
    for v in VGG16_CFG:
        if v == "M":
            layers.append(nn.MaxPool2d(kernel_size=2, stride=2))
        else:
            layers += [nn.Conv2d(channels, int(v), kernel_size=3, padding=1), nn.ReLU(inplace=False)]
            channels = int(v)
    return nn.Sequential(*layers)


class VGGPerceptual(nn.Module):
    """Mean L1 distance between VGG-16 features of two images, summed over the chosen ReLU layers.

    Inputs are ``[B, 3, H, W]`` images roughly in [0, 1] (the loss passes them in its colour space); they are
    normalised with ImageNet statistics. The network is frozen and kept in eval mode.
    """

    def __init__(self, features: nn.Sequential, layers: tuple[int, ...] = DEFAULT_LAYERS) -> None:
        super().__init__()
        if not layers or max(layers) >= len(features) or min(layers) < 0:
            raise ValueError(f"loss.perceptual_layers must index VGG-16 feature layers "
                             f"0..{len(features) - 1}, got {list(layers)}")
        self.layers = tuple(sorted(layers))
        self.features = features[: self.layers[-1] + 1]
        self.features.requires_grad_(False)
        self.register_buffer("mean", torch.tensor(IMAGENET_MEAN).view(1, 3, 1, 1), persistent=False)
        self.register_buffer("std", torch.tensor(IMAGENET_STD).view(1, 3, 1, 1), persistent=False)

    def train(self, mode: bool = True) -> VGGPerceptual:
        """Stay in eval mode whatever the parent does (there is no dropout or BN, but keep it explicit)."""
        return super().train(False)

    def forward(self, x: Tensor, y: Tensor) -> Tensor:
        h = torch.cat([x, y]).sub(self.mean).div(self.std)
        loss = h.new_zeros(())
        for i, layer in enumerate(self.features):
            h = layer(h)
            if i in self.layers:
                fx, fy = h.chunk(2)
                loss = loss + (fx - fy).abs().mean()
        return loss


@dataclass(frozen=True)
class PerceptualStatus:
    """Whether ``L_p`` is on, and why; recorded in ``metrics.json`` as ``perceptual_loss``."""

    on: bool
    reason: str
    weights: str | None = None

    def as_dict(self) -> dict[str, object]:
        return {"on": self.on, "reason": self.reason, "weights": self.weights}


def load_vgg16_features(path: str | Path) -> nn.Sequential:
    """VGG-16 feature layers with weights from a torchvision-format state dict file.

    Raises ``ValueError`` naming the file when it is not such a state dict (missing or misshaped
    ``features.*`` tensors); the classifier's keys, if present, are ignored.
    """
    path = Path(path)
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as err:  # torch raises several types for a truncated or foreign file
        raise ValueError(f"{path}: not a readable torch state dict ({err}); give paths.vgg16_weights a "
                         "torchvision VGG-16 weights file, or null to turn the perceptual loss off") from err
    if isinstance(state, dict) and "state_dict" in state:
        state = state["state_dict"]
    if not isinstance(state, dict):
        raise ValueError(f"{path}: expected a state dict, got {type(state).__name__}")
    features = vgg16_features()
    wanted = features.state_dict()
    got = {k.removeprefix("features."): v for k, v in state.items() if k.startswith("features.")}
    missing = sorted(set(wanted) - set(got))
    if missing:
        raise ValueError(f"{path}: not a torchvision VGG-16 state dict; missing features.{missing[0]} "
                         f"and {len(missing) - 1} more keys")
    for k, v in wanted.items():
        if tuple(got[k].shape) != tuple(v.shape):
            raise ValueError(f"{path}: features.{k} has shape {tuple(got[k].shape)}, VGG-16 needs "
                             f"{tuple(v.shape)}")
    features.load_state_dict({k: got[k].float() for k in wanted})
    return features


def load_perceptual(weights: str | None, layers: tuple[int, ...] = DEFAULT_LAYERS
                    ) -> tuple[VGGPerceptual | None, PerceptualStatus]:
    """The perceptual network from ``paths.vgg16_weights``, or ``None`` with the reason it is off.

    ``None``/empty path: off ("no weights file configured"). A path that does not exist: off, with a warning
    naming it. A file that exists but is not VGG-16: ``ValueError``. The outcome is logged once, here.
    """
    if not weights:
        status = PerceptualStatus(False, "paths.vgg16_weights is null: no VGG-16 weights file configured")
        log.warning("perceptual loss L_p is OFF: %s", status.reason)
        return None, status
    path = Path(weights).expanduser()
    if not path.is_file():
        status = PerceptualStatus(False, f"VGG-16 weights file not found: {path}", str(path))
        log.warning("perceptual loss L_p is OFF: %s", status.reason)
        return None, status
    net = VGGPerceptual(load_vgg16_features(path), tuple(layers))
    status = PerceptualStatus(True, f"VGG-16 weights loaded from {path}", str(path))
    log.info("perceptual loss L_p is ON: %s (layers %s)", status.reason, list(net.layers))
    return net, status

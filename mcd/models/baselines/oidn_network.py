"""The shape of the network OIDN runs, in torch, to count its MACs and parameters (docs/baselines.md "OIDN";
docs/inference.md "OIDN's MACs").

OIDN (``pyoidn``) runs its own network, which torch cannot see, so :mod:`mcd.models.complexity` counts this
replica instead, on the ``meta`` device (shapes only: it holds no weights and never denoises). It is the U-Net
of OIDN's published training code (``training/model.py``, models ``unet`` and ``unet_small``): 16 3x3
convolutions with ReLU, 2x2 max pooling, nearest 2x upsampling and skip concatenations. For the ``RT`` filter
on HDR colour + albedo + normal, OIDN 2.x runs the ``unet`` weights at quality ``high`` and ``balanced`` (that
input has no large model) and the ``unet_small`` weights at ``fast``. OIDN pads the image to a multiple of 16
pixels per axis and, at the sizes benchmarked here (up to 2160x2160 pixels), runs it as one tile, so the count
is of the padded image. ``tests/models/test_oidn_network.py`` checks the layer shapes against the weights
embedded in the installed OIDN library.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

#: Output channels of (enc_conv1, enc_conv2, enc_conv3, enc_conv4, enc_conv5, dec_conv4, dec_conv3,
#: dec_conv2a, dec_conv2b, dec_conv1a, dec_conv1b) per model size (OIDN's ``training/model.py``).
WIDTHS = {
    "unet": (32, 48, 64, 80, 96, 112, 96, 64, 64, 64, 32),
    "unet_small": (32, 32, 32, 32, 32, 64, 64, 64, 32, 32, 32),
}
#: OIDN pads images to a multiple of this many pixels per axis.
ALIGNMENT = 16
#: The model each ``quality`` runs for HDR colour + albedo + normal.
MODEL_OF_QUALITY = {"high": "unet", "balanced": "unet", "fast": "unet_small"}


def _conv(cin: int, cout: int) -> nn.Conv2d:
    return nn.Conv2d(cin, cout, 3, padding=1)


class OIDNUNet(nn.Module):
    """OIDN's U-Net (``model``: ``unet`` or ``unet_small``) on ``in_channels`` inputs, 3 outputs."""

    def __init__(self, model: str = "unet", in_channels: int = 9, out_channels: int = 3) -> None:
        super().__init__()
        ec1, ec2, ec3, ec4, ec5, dc4, dc3, dc2a, dc2b, dc1a, dc1b = WIDTHS[model]
        ic = in_channels
        self.enc = nn.ModuleList([_conv(ic, ec1), _conv(ec1, ec1), _conv(ec1, ec2), _conv(ec2, ec3),
                                  _conv(ec3, ec4), _conv(ec4, ec5), _conv(ec5, ec5)])
        self.dec = nn.ModuleList([_conv(ec5 + ec3, dc4), _conv(dc4, dc4), _conv(dc4 + ec2, dc3),
                                  _conv(dc3, dc3), _conv(dc3 + ec1, dc2a), _conv(dc2a, dc2b),
                                  _conv(dc2b + ic, dc1a), _conv(dc1a, dc1b), _conv(dc1b, out_channels)])

    def forward(self, x: Tensor) -> Tensor:
        """``x``: ``[B, in_channels, H, W]``; returns ``[B, out_channels, H, W]`` (computed on the padded
        image, as OIDN does)."""
        h, w = x.shape[-2:]
        x = inputs = F.pad(x, (0, -w % ALIGNMENT, 0, -h % ALIGNMENT))
        e = self.enc
        x = torch.relu(e[0](x))
        pools = []
        for conv in e[1:5]:  # enc_conv1 .. enc_conv4, each followed by a pool
            x = F.max_pool2d(torch.relu(conv(x)), 2)
            pools.append(x)
        x = torch.relu(e[6](torch.relu(e[5](x))))
        d = self.dec
        for i, skip in enumerate((pools[2], pools[1], pools[0], inputs)):
            x = torch.cat((F.interpolate(x, scale_factor=2, mode="nearest"), skip), 1)
            x = torch.relu(d[2 * i + 1](torch.relu(d[2 * i](x))))
        return d[8](x)[..., :h, :w]

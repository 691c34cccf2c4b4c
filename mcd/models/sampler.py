"""The sampling network ``F_s`` (paper Sec. 4 and 3.1; docs/method.md "Adaptive sampling", "Kernel pool",
"Inputs").

A light U-Net on ``c_1`` (compressed), the G-buffers and two grey images (luminance of ``c_1`` and of the
albedo): 12 channels in, sampling logits ``m̄`` out. With KP it also adjusts the kernel pool from its coarsest
features and predicts the kernel map from its finest features (after the adaptive render, which needs ``m``).
"""

from __future__ import annotations

from functools import partial

from torch import Tensor, nn
from torch.profiler import record_function

from mcd.models.blocks import BlockFactory, ConvReLU
from mcd.models.ghost_conv import FastGhostConv
from mcd.models.kernel_pool import (
    KernelMapHead,
    KernelPool,
    apply_pixel_kernels,
    interpolate_kernels,
    kp_options_of,
)
from mcd.models.unet import UNet

#: Channels the sampling network reads: c_1 (3) + G-buffers (7) + grey c_1 + grey albedo.
SAMPLER_IN = 12


class SamplingNetwork(nn.Module):
    """``F_s``: logits for the sampling map and, with KP, the kernel pool and kernel-map head."""

    def __init__(self, widths: list[int], convs: int, kernel_pool: bool, ghost: bool,
                 ghost_cfg: dict | None = None, kp_cfg: dict | None = None,
                 kp_options: dict | None = None) -> None:
        super().__init__()
        block: BlockFactory = partial(FastGhostConv, **(ghost_cfg or {})) if ghost else ConvReLU
        self.unet = UNet(SAMPLER_IN, 1, widths, convs, block=block)
        self.pool: KernelPool | None = None
        self.head: KernelMapHead | None = None
        if kernel_pool:
            kp = dict(kp_cfg or {})
            head_widths = list(kp.pop("head_widths", [32, 32]))
            options = kp_options_of(kp_options)
            self.pool = KernelPool(widths[-1], **kp)
            head_in = widths[0] + 7 + 3 + self.pool.describe.out_channels
            self.head = KernelMapHead(head_in, head_widths, block, output=options["head_output"])

    def forward(self, x: Tensor) -> dict[str, Tensor]:
        """``{"logits", "finest", "coarsest"}`` for the 12-channel sampler input."""
        y = self.unet(x)
        return {"logits": y["out"], "finest": y["finest"], "coarsest": y["coarsest"]}

    def initial_denoise(self, finest: Tensor, coarsest: Tensor, g: Tensor,
                        image: Tensor) -> dict[str, Tensor]:
        """Kernel map and initial denoise ``i_bar`` of ``image`` (the adaptive image, network range)."""
        if self.pool is None or self.head is None:
            raise RuntimeError("initial_denoise needs the kernel pool (method.KP=true)")
        adjusted = self.pool.adjust(coarsest)
        desc = self.pool.descriptor(adjusted)
        with record_function("kernel-map head"):
            kmap = self.head([finest, g.to(finest.dtype), image.to(finest.dtype)], desc)
        normalised = self.pool.normalised(adjusted)
        with record_function("kernel application"):
            kernels = interpolate_kernels(normalised, kmap.float())
            initial = apply_pixel_kernels(image.float(), kernels)
        return {"kernel_map": kmap, "initial": initial, "pool": normalised}


"""The sampling network ``F_s`` (paper Sec. 4 and 3.1; docs/method.md "Adaptive sampling", "Kernel pool",
"Inputs").

A light U-Net on ``c_1`` (compressed), the G-buffers and two grey images (luminance of ``c_1`` and of the
albedo): 12 channels in, sampling logits ``m̄`` out. With KP it also adjusts the kernel pool from its coarsest
features and predicts the kernel map from its finest features (after the adaptive render, which needs ``m``).
"""

from __future__ import annotations

from functools import partial

from torch import Tensor, nn

from mcd.core.stages import stage
from mcd.models.blocks import BlockFactory, ConvReLU
from mcd.models.ghost_conv import FastGhostConv
from mcd.models.kernel_pool import (
    KernelMapHead,
    KernelPool,
    filter_below,
    interpolate_kernels,
    kp_options_of,
)
from mcd.models.unet import UNet

#: Channels the sampling network reads: c_1 (3) + G-buffers (7) + grey c_1 + grey albedo.
SAMPLER_IN = 12


class SamplingNetwork(nn.Module):
    """``F_s``: logits for the sampling map and, with KP, the kernel pool and kernel-map head.

    ``padding`` is the ``padding_mode`` of every convolution (``method.sampler_padding``): ``replicate`` (the
    config's default) keeps a flat input's logits flat up to the frame's border, so the map spends no samples
    on the border for being the border; ``zeros`` (the paper's text, ``F_paper``) makes the border look like
    an edge (docs/method.md "Adaptive sampling", step 6). ``kp_options``: ``method.kp``, read with KP."""

    def __init__(self, widths: list[int], convs: int, kernel_pool: bool, ghost: bool, *, padding: str,
                 kp_options: dict | None, ghost_cfg: dict | None = None, kp_cfg: dict | None = None) -> None:
        super().__init__()
        block: BlockFactory = (partial(FastGhostConv, **(ghost_cfg or {}), padding=padding) if ghost
                               else partial(ConvReLU, padding=padding))
        self.unet = UNet(SAMPLER_IN, 1, widths, convs, block=block)
        self.pool: KernelPool | None = None
        self.head: KernelMapHead | None = None
        if kernel_pool:
            kp = dict(kp_cfg or {})
            head_widths = list(kp.pop("head_widths"))
            options = kp_options_of(kp_options or {})
            self.pool = KernelPool(widths[-1], **kp)
            head_in = widths[0] + 7 + 3 + self.pool.describe.out_channels
            self.head = KernelMapHead(head_in, head_widths, block, output=options["head_output"],
                                      padding=padding)

    def forward(self, x: Tensor) -> dict[str, Tensor]:
        """``{"logits", "finest", "coarsest"}`` for the 12-channel sampler input."""
        y = self.unet(x)
        return {"logits": y["out"], "finest": y["finest"], "coarsest": y["coarsest"]}

    def initial_denoise(self, finest: Tensor, coarsest: Tensor, g: Tensor, image: Tensor,
                        ceiling: float | None = None, hits: Tensor | None = None) -> dict[str, Tensor]:
        """Kernel map and initial denoise ``i_bar`` of ``image`` (the adaptive image, network range); the
        kernels filter ``image`` below ``ceiling`` (network range; ``method.kp.highlight`` there) and pass
        its excess, and read only the pixels where ``hits`` holds, the others keeping ``image``
        (``method.kp.skip_misses``; :func:`mcd.models.kernel_pool.filter_below`)."""
        if self.pool is None or self.head is None:
            raise RuntimeError("initial_denoise needs the kernel pool (method.KP=true)")
        adjusted = self.pool.adjust(coarsest)
        desc = self.pool.descriptor(adjusted)
        with stage("kernel-map head"):
            kmap = self.head([finest, g.to(finest.dtype), image.to(finest.dtype)], desc)
        normalised = self.pool.normalised(adjusted)
        with stage("kernel application"):
            kernels = interpolate_kernels(normalised, kmap.float())
            initial = filter_below(image.float(), kernels, ceiling, hits)
        return {"kernel_map": kmap, "initial": initial, "pool": normalised}


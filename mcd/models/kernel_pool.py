"""Kernel pool: adjustment, interpolation, per-pixel application (paper Sec. 4.1; docs/method.md "Kernel
pool").

- Pool ``pi``: ``q`` learnable ``l x l`` kernels, initialised Bernoulli(0.5) in {0, 1} (the paper).
- Adjustment: ``F_s``'s coarsest features -> adaptive average pool to ``l x l`` -> MLP lifting channels to
  ``q`` -> 1-D convolution over the kernel index (window 5) = residual ``r``; gate ``alpha = sigmoid(MLP(pi +
  r))`` per kernel; ``pi_bar = (1 - alpha) pi + alpha r``.
- Descriptor: a convolution with an ``l x l`` kernel reduces ``pi_bar`` (``q`` channels) to a short vector.
- Kernel map ``h`` (2 channels, tanh): from ``F_s``'s finest features, ``g``, the adaptive image ``i`` and the
  descriptor (broadcast over the image), through a few conv blocks (Fast GhostConv when FG is on, as every
  block of ``F_s``). What enters the final ``tanh`` is ``method.kp.head_output`` (docs/kernel_pool.md):
  ``tanh`` = the head's output ``z`` as it is (the paper's text); ``rms_centred`` = ``z`` with the
  kernel index's (channel 0's) mean over the image removed, then divided by its root mean square over the
  image, per channel: ``tanh`` then cannot saturate everywhere, so the pool keeps receiving gradient, and the
  index spreads across the pool instead of settling on one kernel everywhere (docs/kernel_pool.md tells how
  the map saturated without it). ``rms_soft`` = the same kernel index, and the identity channel divided by
  ``sqrt(mean(z^2) + 1)`` instead of its RMS: ``rms_centred`` maps a near-constant identity channel to +-1 by
  its sign alone, so one step that moved its mean across zero flipped every pixel between 12% and 88%
  identity (the early loss jump of docs/method.md "The early loss jump"); with the floor of 1 under the RMS
  the channel is continuous in ``z`` and still cannot saturate (``|z| >> 1`` is scaled to an RMS of 1). The
  default: it scored above ``rms_centred`` in the scaling study (docs/method.md "F against the paper").
- Interpolation: one ``grid_sample`` over a ``q x 2`` table whose columns are ``softmax(pi_bar)`` (softmax
  over each kernel's taps) and the identity kernel: ``h[0]`` picks a position along the pool, ``h[1]`` moves
  between that kernel and the identity.
- Application: ``i_bar(p) = sum_taps kernel_p(tap) * i(p + tap)``, per channel (replicate padding at borders).
"""

from __future__ import annotations

from typing import Any

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from mcd.models import fast_paths
from mcd.models.blocks import BlockFactory, on_parts
from mcd.models.cpu_fast.layout import memory_format
from mcd.models.cpu_fast.replicate import padded_conv, replicate_conv, replicate_conv_applies, replicate_pad


def apply_pixel_kernels(image: Tensor, kernels: Tensor) -> Tensor:
    """Filter ``image`` ``[B, C, H, W]`` with per-pixel kernels ``[B, l*l, H, W]`` (row-major taps).

    One in-place multiply-add (``addcmul_``) per tap of shifted views of the padded image, so no temporary
    is larger than the image: ``unfold`` + ``einsum`` holds an ``l*l``-times larger tensor and was slower on
    the CPU (docs/inference.md, "Kernel application"). Runs in the kernels' dtype promoted with
    the image's. Fast path (:mod:`mcd.models.fast_paths`): the passes run with the image and the output in
    the kernels' memory layout (a channels-last image against plain kernels made every pass a strided one,
    2.2x slower on the CPU: docs/inference.md "Fast paths"), and the output is handed back in the image's;
    where a gradient is taken, the backward is :class:`PixelKernels`'s.
    """
    taps = kernels.shape[1]
    size = int(round(taps ** 0.5))
    if size * size != taps or size % 2 == 0:
        raise ValueError(f"per-pixel kernels need an odd square number of taps; got {taps}")
    r = size // 2
    dtype = torch.promote_types(image.dtype, kernels.dtype)
    layout = memory_format(image)
    if fast_paths.enabled():
        image = image.contiguous(memory_format=memory_format(kernels))
    padded = replicate_pad(image.to(dtype), (r, r, r, r))
    kernels = kernels.to(dtype)
    if fast_paths.enabled() and torch.is_grad_enabled() and (padded.requires_grad or kernels.requires_grad):
        out = PixelKernels.apply(padded, kernels)
    else:
        out = pixel_kernel_passes(padded, kernels)
    return out.contiguous(memory_format=layout)


def pixel_kernel_passes(padded: Tensor, kernels: Tensor) -> Tensor:
    """:func:`apply_pixel_kernels` on the image already padded by ``l // 2`` on each side, in ``kernels``'s
    dtype: one ``addcmul_`` per tap of a shifted view."""
    taps = kernels.shape[1]
    size = int(round(taps ** 0.5))
    h, w = kernels.shape[-2:]
    out = torch.zeros_like(padded[..., :h, :w], dtype=kernels.dtype)
    for t in range(taps):
        dy, dx = divmod(t, size)
        out.addcmul_(kernels[:, t : t + 1], padded[..., dy : dy + h, dx : dx + w])
    return out


class PixelKernels(torch.autograd.Function):
    """:func:`pixel_kernel_passes` with its backward written out (fast path, :mod:`mcd.models.fast_paths`).

    Autograd's backward of the ``l*l`` in-place multiply-adds built, per tap, a zero tensor the size of the
    padded image and one the size of the kernels around each tap's gradient (the shifted views' backward)
    and added them all up, at 40 times the forward's time on the CPU (notes/f_speed.md "The training
    step"). Here each tap's gradients are computed as autograd computes
    them (``addcmul``'s derivative: ``(grad * view).sum(1)`` for the kernel's channel, ``grad * kernel`` for
    the view) and written into, or added to, one gradient tensor each, the taps in the order autograd adds
    them (the last first). The same values as autograd's: ``tests/models/test_fast_paths.py``."""

    @staticmethod
    def forward(ctx, padded: Tensor, kernels: Tensor) -> Tensor:  # noqa: ANN001
        ctx.save_for_backward(padded, kernels)
        return pixel_kernel_passes(padded, kernels)

    @staticmethod
    def backward(ctx, grad: Tensor) -> tuple[Tensor | None, Tensor | None]:  # noqa: ANN001
        padded, kernels = ctx.saved_tensors
        taps = kernels.shape[1]
        size = int(round(taps ** 0.5))
        h, w = kernels.shape[-2:]
        grad_padded = grad_kernels = None
        if ctx.needs_input_grad[1]:
            grad_kernels = torch.empty_like(kernels)
            for t in range(taps):
                dy, dx = divmod(t, size)
                view = padded[..., dy : dy + h, dx : dx + w]
                grad_kernels[:, t : t + 1] = (grad * view).sum(1, keepdim=True)
        if ctx.needs_input_grad[0]:
            grad_padded = torch.zeros_like(padded)
            for t in reversed(range(taps)):
                dy, dx = divmod(t, size)
                grad_padded[..., dy : dy + h, dx : dx + w] += grad * kernels[:, t : t + 1]
        return grad_padded, grad_kernels


def filter_below(image: Tensor, kernels: Tensor, ceiling: float | None, hits: Tensor | None = None) -> Tensor:
    """:func:`apply_pixel_kernels` of ``min(image, ceiling)``, plus what ``image`` holds above ``ceiling``
    at the pixel itself (``ceiling`` in ``image``'s range; None: the kernels on ``image`` as it is).

    A pool kernel is a blur (softmax taps, all positive), applied in the compressed range: next to a light
    source it spread the light's log value over the dark pixels around it (a ring several times brighter
    than the reference) and took most of the light's own energy away (docs/method.md "Kernel pool"). Above
    the ceiling a pixel's excess is no noise for a 5x5 blur to spread; it stays where it is, and the
    pixels around it see the light at the ceiling only.

    ``hits`` (``[B, 1, H, W]``, bool; ``method.kp.skip_misses``): where False (a pixel that saw no geometry,
    :func:`mcd.models.misses.miss_mask`) the pixel keeps ``image``, and no kernel reads it: each kernel's taps
    on such pixels are dropped and the rest renormalised (a normalised convolution). Such a pixel is already
    noise-free (:mod:`mcd.models.misses`); blurred, it put light into the Cornell box's black frame and
    darkened the rows beside it (docs/method.md "Kernel pool").
    """
    below = image if ceiling is None else image.clamp_max(ceiling)
    if hits is None:
        return apply_pixel_kernels(below, kernels) + (image - below)
    weight = hits.to(image.dtype)
    total = apply_pixel_kernels(weight, kernels)
    filtered = apply_pixel_kernels(below * weight, kernels) / total.clamp_min(1e-12)
    # a hit pixel's own tap is positive (softmax taps, blended with the identity), so total > 0 there
    return torch.where(hits & (total > 0), filtered + (image - below), image)


def identity_kernel(size: int) -> Tensor:
    """``l*l`` taps, 1 at the centre."""
    k = torch.zeros(size * size)
    k[(size * size) // 2] = 1.0
    return k


def interpolate_kernels(pool: Tensor, h: Tensor) -> Tensor:
    """Per-pixel kernels ``[B, l*l, H, W]`` from normalised pool kernels ``[B, q, l*l]`` and kernel map ``h``.

    ``h`` ``[B, 2, H, W]`` in [-1, 1]: channel 0 runs along the pool (-1 first kernel, +1 last), channel 1
    from the pool kernel (-1) to the identity kernel (+1). One bilinear ``grid_sample`` over the ``q x 2``
    table.
    """
    b, q, taps = pool.shape
    ident = identity_kernel(int(round(taps ** 0.5))).to(pool)
    table = torch.stack([pool, ident.expand(b, q, taps)], dim=-1).transpose(1, 2)     # [B, taps, q, 2]
    grid = torch.stack([h[:, 1], h[:, 0]], dim=-1).to(table.dtype)                 # x: column, y: kernel
    return F.grid_sample(table, grid, mode="bilinear", padding_mode="border", align_corners=True)


def pool_picture(pool: Tensor, size: int, columns: int = 16) -> Tensor:
    """The kernels ``[B, q, l*l]`` tiled row-major into one image ``[B, 1, rows*(l+1)-1, columns*(l+1)-1]``
    (a one-pixel gap of NaN-free zeros between kernels), kernel ``k`` at row ``k // columns``."""
    b, q, _ = pool.shape
    rows = -(-q // columns)
    tiles = pool.new_zeros(b, rows * columns, size + 1, size + 1)
    tiles[:, :q, :size, :size] = pool.reshape(b, q, size, size)
    tiles = tiles.reshape(b, rows, columns, size + 1, size + 1).permute(0, 1, 3, 2, 4)
    return tiles.reshape(b, 1, rows * (size + 1), columns * (size + 1))[..., :-1, :-1]


def identity_weight(h: Tensor) -> Tensor:
    """Per-pixel weight ``[B, H, W]`` of the identity kernel in :func:`interpolate_kernels`,
    ``(h[1] + 1) / 2``: 1 = ``i_bar`` is ``i`` at that pixel, 0 = the pool kernel only."""
    return (h[:, 1].float() + 1) / 2


class KernelPool(nn.Module):
    """The pool ``pi`` and its per-input adjustment from the sampler's coarsest features; its sizes are the
    capacity profile's ``capacity.two_stage.kernel_pool`` (conf/capacity/), without defaults of their own."""

    def __init__(self, coarse_channels: int, *, q: int, size: int, lift_hidden: int, alpha_hidden: int,
                 window: int, descriptor: int) -> None:
        super().__init__()
        self.q, self.size = q, size
        taps = size * size
        self.pool = nn.Parameter(torch.bernoulli(torch.full((q, taps), 0.5)))
        self.lift = nn.Sequential(nn.Linear(coarse_channels, lift_hidden), nn.ReLU(inplace=True),
                                  nn.Linear(lift_hidden, q))
        self.neighbours = nn.Conv1d(taps, taps, window, padding=window // 2)
        self.alpha = nn.Sequential(nn.Linear(taps, alpha_hidden), nn.ReLU(inplace=True),
                                   nn.Linear(alpha_hidden, 1))
        self.describe = nn.Conv2d(q, descriptor, size)

    def adjust(self, coarse: Tensor) -> Tensor:
        """Adjusted pool ``pi_bar`` ``[B, q, l*l]`` for one input, from features ``[B, C, h, w]``."""
        pooled = F.adaptive_avg_pool2d(coarse, self.size).flatten(2).transpose(1, 2)        # [B, l*l, C]
        lifted = self.lift(pooled)                                                            # [B, l*l, q]
        residual = self.neighbours(lifted).transpose(1, 2)                                    # [B, q, l*l]
        alpha = torch.sigmoid(self.alpha(self.pool + residual))                               # [B, q, 1]
        return (1 - alpha) * self.pool + alpha * residual

    def descriptor(self, adjusted: Tensor) -> Tensor:
        """Short vector ``[B, D]`` describing the adjusted pool."""
        b = adjusted.shape[0]
        return self.describe(adjusted.reshape(b, self.q, self.size, self.size)).flatten(1)

    @staticmethod
    def normalised(adjusted: Tensor) -> Tensor:
        """``softmax`` over each kernel's taps, in fp32."""
        return torch.softmax(adjusted.float(), dim=-1)


#: What enters the kernel-map head's final ``tanh`` (``method.kp.head_output``; see the module docstring).
HEAD_OUTPUTS = ("tanh", "rms_centred", "rms_soft")


#: The keys of ``method.kp``, each without a default of its own: conf/method/two_stage.yaml gives them.
KP_OPTIONS = ("head_output", "highlight", "skip_misses")


def kp_options_of(options: dict) -> dict[str, Any]:
    """``method.kp`` as the kernel pool reads it: ``{"head_output": ..., "highlight": ..., "skip_misses":
    ...}``, every key given (conf/method/two_stage.yaml holds their values, and docs/method.md "Kernel pool"
    says why ``skip_misses`` stays off).

    A missing, unknown or out-of-range key is refused, naming it.
    """
    options = dict(options)
    missing = [k for k in KP_OPTIONS if k not in options]
    if missing:
        raise ValueError(f"method.kp lacks {', '.join(missing)}: give each of {', '.join(KP_OPTIONS)} "
                         "(conf/method/two_stage.yaml has them)")
    head_output = str(options.pop("head_output"))
    highlight = options.pop("highlight")
    skip_misses = options.pop("skip_misses")
    if options:
        raise ValueError(f"method.kp: unknown option(s) {sorted(options)}; the options are head_output "
                         f"({' | '.join(HEAD_OUTPUTS)}), highlight (a linear value > 0, or null) and "
                         f"skip_misses (true or false)")
    if highlight is not None and not float(highlight) > 0:
        raise ValueError(f"method.kp.highlight={highlight}: give a linear value > 0 (the pool filters what "
                         "lies below it) or null (it filters every value)")
    if not isinstance(skip_misses, bool):
        raise ValueError(f"method.kp.skip_misses={skip_misses!r}: give true or false")
    return {"head_output": head_output, "highlight": None if highlight is None else float(highlight),
            "skip_misses": skip_misses}


class KernelMapHead(nn.Module):
    """Kernel map ``h`` ``[B, 2, H, W]`` in (-1, 1) from (finest features, g, i, descriptor); ``padding`` is
    the last convolution's ``padding_mode`` (``block`` has its own: mcd.models.sampler.SamplingNetwork) and
    ``output`` is ``method.kp.head_output``, both without defaults of their own."""

    def __init__(self, cin: int, widths: list[int], block: BlockFactory, *, output: str,
                 padding: str) -> None:
        super().__init__()
        if output not in HEAD_OUTPUTS:
            raise ValueError(f"method.kp.head_output={output!r}: expected one of {HEAD_OUTPUTS}")
        self.output = output
        layers: list[nn.Module] = []
        for w in widths:
            layers.append(block(cin, w))
            cin = w
        self.blocks = nn.Sequential(*layers)
        self.out = nn.Conv2d(cin, 2, 3, padding=1, padding_mode=padding)

    def scale(self, z: Tensor) -> Tensor:
        """What enters ``tanh`` for the head's raw output ``z`` (``output``: as is, or RMS-normalised with the
        kernel index's mean over the image removed first; ``rms_soft``: the identity channel's RMS
        floored)."""
        if self.output == "tanh":
            return z
        index = z[:, :1]
        z = torch.cat([index - index.mean((-2, -1), keepdim=True), z[:, 1:]], dim=1)
        square = z.float().square().mean((-2, -1), keepdim=True)
        if self.output == "rms_soft":  # the identity channel over sqrt(mean square + 1): continuous in z
            square = torch.cat([square[:, :1], square[:, 1:] + 1.0], dim=1)
        return z * torch.rsqrt(square + 1e-6).to(z.dtype)

    def forward(self, parts: list[Tensor], constant: Tensor) -> Tensor:
        """``h`` from the channel concatenation of ``parts`` (finest features, g, i) and of ``constant``
        ``[B, D]`` (the kernel descriptor) broadcast over the image. The first block is handed them as they
        are (:func:`mcd.models.blocks.on_parts`): a Fast GhostConv block on the CPU in inference mode does not
        convolve the constant channels (docs/inference.md). A replicate-padded last convolution runs, in CPU
        inference, on its input padded once by slices
        (:func:`mcd.models.cpu_fast.replicate.replicate_conv`)."""
        x = self.blocks[1:](on_parts(self.blocks[0], parts, constant))
        if fast_paths.enabled() and replicate_conv_applies(self.out, x):
            z = replicate_conv(self.out, x)
        else:
            z = padded_conv(self.out, x)
        return torch.tanh(self.scale(z))

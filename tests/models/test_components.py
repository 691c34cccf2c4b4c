"""Kernel pool, position-aware pooling, semantic alignment, Fast GhostConv (docs/method.md, one section
each)."""

import pytest
import torch
import torch.nn.functional as F

from mcd.models.cpu_fast.ghost_conv import grouped_conv
from mcd.models.ghost_conv import FastGhostConv
from mcd.models.kernel_pool import KernelPool, apply_pixel_kernels, identity_kernel, interpolate_kernels
from mcd.models.position_pooling import PositionAwarePool
from mcd.models.semantic_alignment import SemanticAlignment


def _pool_kernels(b=2, q=8, taps=25, seed=0):
    torch.manual_seed(seed)
    return torch.softmax(torch.randn(b, q, taps), -1)


def test_identity_weight_one_returns_the_input():
    image = torch.rand(2, 3, 9, 11) * 1e3
    h = torch.empty(2, 2, 9, 11).uniform_(-1, 1)
    h[:, 1] = 1.0                                            # all the way to the identity kernel
    kernels = interpolate_kernels(_pool_kernels(), h)
    torch.testing.assert_close(kernels, identity_kernel(5).view(1, 25, 1, 1).expand(2, 25, 9, 11))
    torch.testing.assert_close(apply_pixel_kernels(image, kernels), image)


def test_interpolation_along_the_pool_is_linear_between_neighbours():
    pool = _pool_kernels(b=1, q=5)
    h = torch.full((1, 2, 1, 3), -1.0)
    h[0, 0, 0] = torch.tensor([-1.0, 1.0, -0.25])           # kernel 0, kernel 4, halfway between 1 and 2
    k = interpolate_kernels(pool, h)[0, :, 0].T              # [3, taps]
    torch.testing.assert_close(k[0], pool[0, 0])
    torch.testing.assert_close(k[1], pool[0, 4])
    torch.testing.assert_close(k[2], 0.5 * (pool[0, 1] + pool[0, 2]))
    h[0, 1] = 0.0                                            # halfway to the identity
    k = interpolate_kernels(pool, h)[0, :, 0].T
    torch.testing.assert_close(k[0], 0.5 * pool[0, 0] + 0.5 * identity_kernel(5))


def test_pixel_kernels_match_unfold_and_keep_constants():
    torch.manual_seed(1)
    image = torch.rand(2, 3, 7, 6)
    kernels = torch.softmax(torch.randn(2, 25, 7, 6), 1)
    patches = F.unfold(F.pad(image, (2, 2, 2, 2), mode="replicate"), 5).view(2, 3, 25, 7, 6)
    torch.testing.assert_close(apply_pixel_kernels(image, kernels), (patches * kernels[:, None]).sum(2))
    flat = torch.full((1, 3, 5, 5), 7.0)
    torch.testing.assert_close(apply_pixel_kernels(flat, kernels[:1, :, :5, :5]), flat)


def test_kernel_pool_adjustment_shapes_init_and_gradients():
    kp = KernelPool(coarse_channels=12, q=16, size=5, lift_hidden=8, alpha_hidden=8, window=5, descriptor=4)
    assert set(kp.pool.detach().unique().tolist()) <= {0.0, 1.0}, "Bernoulli(0.5) init in {0, 1}"
    adjusted = kp.adjust(torch.rand(2, 12, 3, 5))
    assert adjusted.shape == (2, 16, 25)
    assert kp.descriptor(adjusted).shape == (2, 4)
    (kp.normalised(adjusted).square().sum() + kp.descriptor(adjusted).sum()).backward()
    assert all(p.grad is not None for p in kp.parameters())


@pytest.mark.parametrize(("bias", "alpha"), [(-30.0, 0.0), (0.0, 0.5), (30.0, 1.0)])
def test_kernel_pool_gate_blends_pool_and_residual(bias, alpha):
    """With the gate MLP's output fixed (last layer weight 0, bias b), alpha = sigmoid(b) and
    pi_bar = (1 - alpha) pi + alpha r: b = -30 keeps the pool, b = 30 takes the residual r."""
    torch.manual_seed(0)
    kp = KernelPool(coarse_channels=12, q=16, size=5, lift_hidden=8, alpha_hidden=8, window=5, descriptor=4)
    with torch.no_grad():
        kp.alpha[-1].weight.zero_()
        kp.alpha[-1].bias.fill_(bias)
    coarse = torch.rand(2, 12, 3, 5)
    pooled = F.adaptive_avg_pool2d(coarse, 5).flatten(2).transpose(1, 2)
    residual = kp.neighbours(kp.lift(pooled)).transpose(1, 2)             # r of docs/method.md, [B, q, taps]
    assert (residual - kp.pool).abs().mean() > 0.1                       # the two ends differ
    torch.testing.assert_close(kp.adjust(coarse), (1 - alpha) * kp.pool + alpha * residual)


@pytest.mark.parametrize("size", [(7, 9), (1, 1), (8, 8), (5, 2)])
def test_position_pooling_odd_sizes_and_constant_image(size):
    torch.manual_seed(0)
    pool = PositionAwarePool(4, hidden=3)
    constant = torch.full((2, 4, *size), 2.5)
    out = pool(constant)
    assert out.shape == (2, 4, (size[0] + 1) // 2, (size[1] + 1) // 2)
    torch.testing.assert_close(out, torch.full_like(out, 2.5))
    x = torch.randn(2, 4, *size, requires_grad=True)
    y = pool(x)
    y.sum().backward()
    assert torch.isfinite(x.grad).all()


def test_position_pooling_is_a_convex_combination_of_the_window():
    torch.manual_seed(0)
    pool = PositionAwarePool(3)
    x = torch.randn(1, 3, 6, 8)
    windows = F.pixel_unshuffle(x, 2).view(1, 3, 4, 3, 4)
    out = pool(x)
    assert bool((out <= windows.amax(2) + 1e-6).all() and (out >= windows.amin(2) - 1e-6).all())
    with torch.no_grad():                                    # equal scores: the plain window average
        pool.score.weight.zero_()
        pool.score.bias.zero_()
    torch.testing.assert_close(pool(x), windows.mean(2))


def test_position_pooling_uses_position():
    """Identical members in different windows get different weights once the score reads position."""
    pool = PositionAwarePool(1)
    with torch.no_grad():
        pool.score.weight.zero_()
        pool.score.weight[0, 1] = 5.0                        # channel 1 = absolute x
    x = torch.arange(16.0).view(1, 1, 4, 4)
    out = pool(x)
    windows = F.pixel_unshuffle(x, 2).view(1, 1, 4, 2, 2)
    assert bool((out > windows.mean(2)).all()), "the right-hand members (larger x) weigh more"


def test_semantic_alignment_repeated_frame_state_and_reset():
    torch.manual_seed(0)
    sa = SemanticAlignment(16, heads=4)
    x = torch.randn(2, 16, 5, 7, requires_grad=True)
    first = sa(x)                                            # first frame attends to itself
    second = sa(x)                                           # same frame again: attends to `first`
    assert not torch.allclose(first, second), "the state of the previous frame is used"
    sa.reset()
    torch.testing.assert_close(sa(x), first)                 # after reset: as the first frame again
    sa.reset()
    a = sa(x)
    b = sa(x.detach())                                       # gradient reaches frame 1 through the state
    b.sum().backward()
    assert x.grad is not None and float(x.grad.abs().sum()) > 0
    assert a.shape == x.shape


def test_semantic_alignment_shape_change_asks_for_reset():
    sa = SemanticAlignment(8, heads=4)
    sa(torch.randn(1, 8, 4, 4))
    with pytest.raises(RuntimeError, match="reset"):
        sa(torch.randn(1, 8, 4, 6))


def test_fast_ghostconv_is_cheaper_than_a_3x3_block_and_widens_the_field():
    g = FastGhostConv(48, 48)
    conv = torch.nn.Conv2d(48, 48, 3, padding=1)
    count = lambda m: sum(p.numel() for p in m.parameters())   # noqa: E731
    assert count(g) < count(conv)
    x = torch.zeros(1, 48, 15, 15, requires_grad=True)
    g(x)[0, :, 7, 7].sum().backward()
    reach = x.grad[0].abs().sum(0).nonzero()
    assert int(reach[:, 0].max() - reach[:, 0].min()) + 1 == 9, "7x7 group conv + 3x3 ghost: 9x9 field"
    out = FastGhostConv(12, 16, groups=8)(torch.rand(1, 12, 6, 6))   # groups fall back to gcd(8, 12, 8) = 4
    assert out.shape == (1, 16, 6, 6) and bool((out >= 0).all())
    with pytest.raises(ValueError, match="even output width"):
        FastGhostConv(8, 7)


def test_cpu_training_path_of_grouped_convs_equals_the_grouped_conv():
    torch.manual_seed(0)
    conv = torch.nn.Conv2d(12, 8, 7, padding=3, groups=4)
    x = torch.randn(2, 12, 9, 10, requires_grad=True)
    dense = grouped_conv(conv, x)                            # grad enabled on CPU: masked dense weight
    dense.square().sum().backward()
    grads = (x.grad.clone(), conv.weight.grad.clone())
    x.grad, conv.weight.grad = None, None
    plain = conv(x)
    plain.square().sum().backward()
    torch.testing.assert_close(dense, plain)
    torch.testing.assert_close(grads[0], x.grad)
    torch.testing.assert_close(grads[1], conv.weight.grad)


def test_kernel_map_head_outputs_bound_what_enters_tanh():
    """``method.kp.head_output`` (docs/kernel_pool.md): ``rms_centred`` removes the kernel index's mean and
    gives each channel RMS 1 over the image, so a head whose index channel is one large offset plus small
    variations (row J's case) still spreads the index across the pool; ``tanh`` passes ``z`` as it is."""
    from mcd.models.blocks import ConvReLU
    from mcd.models.kernel_pool import KernelMapHead

    torch.manual_seed(0)
    z = torch.stack([50.0 + 0.1 * torch.randn(2, 9, 11), 3.0 * torch.randn(2, 9, 11)], dim=1)
    heads = {o: KernelMapHead(4, [4], ConvReLU, output=o, padding="zeros") for o in ("tanh", "rms_centred")}
    assert torch.tanh(z[:, 0]).std((-2, -1)).max() < 1e-3             # as is: one kernel everywhere
    centred = heads["rms_centred"].scale(z)
    assert centred[:, 0].mean((-2, -1)).abs().max() < 0.05             # up to fp32 cancellation
    assert torch.allclose(centred.square().mean((-2, -1)), torch.ones(2, 2), atol=1e-3)
    assert torch.tanh(centred[:, 0]).std((-2, -1)).min() > 0.5        # the index spreads across the pool
    identity = z[:, 1] * torch.rsqrt(z[:, 1].square().mean((-2, -1), keepdim=True) + 1e-6)
    torch.testing.assert_close(centred[:, 1], identity)                # the identity channel: RMS only
    assert torch.equal(heads["tanh"].scale(z), z)
    with pytest.raises(ValueError, match="head_output"):
        KernelMapHead(4, [4], ConvReLU, output="softsign", padding="zeros")


def test_the_soft_identity_channel_is_continuous_where_rms_centred_flips_every_pixel():
    """``rms_soft`` (docs/kernel_pool.md, docs/method.md "The early loss jump"): an identity channel that is
    one small offset plus smaller variations. Under ``rms_centred`` moving the offset from -0.01 to +0.01
    flips every pixel from 12% to 88% identity (``(tanh + 1) / 2``); under ``rms_soft`` the share moves by
    under 1%, and a large channel (50) is still scaled down so that ``tanh`` does not saturate. The kernel
    index is the same under both."""
    from mcd.models.blocks import ConvReLU
    from mcd.models.kernel_pool import KernelMapHead

    torch.manual_seed(0)
    noise = 1e-3 * torch.randn(1, 9, 11)
    index = torch.randn(1, 9, 11)
    share = {}
    for output in ("rms_centred", "rms_soft"):
        head = KernelMapHead(4, [4], ConvReLU, output=output, padding="zeros")
        h = [torch.tanh(head.scale(torch.stack([index, c + noise], dim=1))[:, 1]) for c in (-0.01, 0.01)]
        share[output] = [float((x + 1).mean() / 2) for x in h]
        large = head.scale(torch.stack([index, 50.0 + noise], dim=1))
        assert float(torch.tanh(large[:, 1]).max()) < 0.8                  # no saturation at the identity
    assert share["rms_centred"][0] < 0.13 and share["rms_centred"][1] > 0.87
    assert abs(share["rms_soft"][1] - share["rms_soft"][0]) < 0.01
    z = torch.stack([index, 0.3 + noise], dim=1)
    soft, centred = (KernelMapHead(4, [4], ConvReLU, output=o, padding="zeros").scale(z)
                     for o in ("rms_soft", "rms_centred"))
    torch.testing.assert_close(soft[:, 0], centred[:, 0])


def test_kernel_pool_options_are_checked_by_name():
    """``method.kp``: a missing key (the options have no defaults of their own: the YAML gives them) or a
    value outside its range is refused naming the key, and an unknown key (the options removed before the
    bundled checkpoints were saved again included) is refused."""
    from mcd.models.kernel_pool import kp_options_of

    given = {"head_output": "rms_centred", "highlight": 4, "skip_misses": True}
    assert kp_options_of(given) == {**given, "highlight": 4.0}
    assert kp_options_of({**given, "highlight": None})["highlight"] is None
    with pytest.raises(ValueError, match="method.kp lacks head_output, highlight, skip_misses"):
        kp_options_of({})
    with pytest.raises(ValueError, match="method.kp lacks highlight"):
        kp_options_of({"head_output": "tanh", "skip_misses": False})
    with pytest.raises(ValueError, match="method.kp.highlight"):
        kp_options_of({**given, "highlight": 0})
    with pytest.raises(ValueError, match="method.kp.skip_misses"):
        kp_options_of({**given, "skip_misses": "yes"})
    for removed in ({"denoiser_reads_adaptive": False}, {"temperature": 1.0}, {"head_outptu": "tanh"}):
        with pytest.raises(ValueError, match="unknown option"):
            kp_options_of({**given, **removed})


@pytest.mark.parametrize("ceiling", [None, 4.0])
def test_the_pool_spreads_no_light_into_the_dark_around_it(ceiling):
    """A 3x3 light of 1e5 on a flat 0.3 wall, blurred by the 5x5 box (the pool's widest kernel) in the
    network range (``log1p``), as the kernel pool does: below ``method.kp.highlight`` (4) the wall next to
    the light stays below 1 and the light keeps 40% of its value; filtering every value (a config from
    before the option) made a ring of up to 18 around the light and took the light down to 74
    (docs/method.md "Kernel pool")."""
    from mcd.models.inputs import compress, expand
    from mcd.models.kernel_pool import filter_below

    image = torch.full((1, 3, 15, 15), 0.3)
    image[..., 6:9, 6:9] = 1e5
    kernels = torch.full((1, 25, 15, 15), 1 / 25)
    top = None if ceiling is None else float(compress(torch.tensor(ceiling)))
    out = expand(filter_below(compress(image), kernels, top))
    ring = torch.zeros(15, 15, dtype=torch.bool)
    ring[4:11, 4:11] = True
    ring[6:9, 6:9] = False
    far = out[..., :2, :]
    torch.testing.assert_close(far, torch.full_like(far, 0.3))
    if ceiling is None:
        assert float(out[..., ring].max()) > 10 and float(out[..., 6:9, 6:9].max()) < 100
    else:
        assert float(out[..., ring].max()) < 1 and float(out[..., 6:9, 6:9].min()) > 4e4


@pytest.mark.parametrize("ceiling, line_max", [(1.0, 1.0), (4.0, None)])
def test_a_lower_highlight_keeps_a_thin_dark_line_beside_a_bright_window_dark(ceiling, line_max):
    """A one-pixel dark line of 0.0077 between two walls of 4.6: bathroom's window mullions and the window
    under that scene's exposure in `small`, the window just above the default ceiling of 4. Blurred by the
    5x5 box in the network range, as the kernel pool does: below ``method.kp.highlight=1`` the line stays
    below 1 (0.74); below the default 4 it comes out above 2 (2.6, a relative squared error of about 680 per
    pixel: such pixels carried most of F's rMSE on bathroom, docs/method.md "Thin dark lines beside a bright
    window"). The window keeps its value either way."""
    from mcd.models.inputs import compress, expand
    from mcd.models.kernel_pool import filter_below

    image = torch.full((1, 3, 15, 15), 4.6)
    image[..., 7] = 0.0077
    kernels = torch.full((1, 25, 15, 15), 1 / 25)
    out = expand(filter_below(compress(image), kernels, float(compress(torch.tensor(ceiling)))))
    line = float(out[..., 7:8].max())
    torch.testing.assert_close(out[..., :4], torch.full_like(out[..., :4], 4.6))
    assert line < line_max if line_max is not None else line > 2


@pytest.mark.parametrize("skip", [False, True])
def test_the_pool_neither_reads_nor_changes_pixels_that_saw_no_geometry(skip):
    """A flat 0.3 wall inside a two-pixel black frame of escaped rays (G-buffer normal 0, as around the
    Cornell box), noisy, blurred by the 5x5 box: with ``method.kp.skip_misses`` the frame stays exactly 0
    and the wall beside it keeps the wall's level (a normalised convolution over the hit pixels); filtering
    across it put light into the frame and darkened the wall's outer row by half (docs/method.md
    "Kernel pool")."""
    from mcd.models.inputs import compress, expand
    from mcd.models.kernel_pool import filter_below
    from mcd.models.misses import miss_mask

    gen = torch.Generator().manual_seed(0)
    image = 0.3 * (1 + 0.2 * torch.randn(1, 3, 16, 16, generator=gen)).clamp_min(0)
    normal = torch.zeros(1, 3, 16, 16)
    normal[:, 2, 2:-2, 2:-2] = 1.0
    image = torch.where(miss_mask(normal), torch.zeros(()), image)
    kernels = torch.full((1, 25, 16, 16), 1 / 25)
    hits = ~miss_mask(normal) if skip else None
    out = expand(filter_below(compress(image), kernels, float(compress(torch.tensor(4.0))), hits))
    frame = miss_mask(normal).expand_as(out)
    edge_rows = out[..., 2, 2:-2]
    if skip:
        assert float(out[frame].abs().max()) == 0.0
        assert float(edge_rows.mean()) == pytest.approx(0.3, rel=0.06)
    else:
        assert float(out[frame].max()) > 0.05
        assert float(edge_rows.mean()) < 0.3 * 0.75

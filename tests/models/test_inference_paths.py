"""CPU inference fast paths (docs/inference.md) against fp32 eager reference formulations: lane-filled group
convolutions, oneDNN post-ops (fused ReLU, in-place sums, decoder blocks on parts), in-place kernel
application, position-aware pooling without temporaries, sort-free map normalisation, whole rows in fp32, and
the whole row F along the bench's fastest path against fp32 eager."""

from __future__ import annotations

import pytest
import torch
import torch.nn.functional as F

from mcd.lit.precision import cpu_bf16_supported
from mcd.models import build
from mcd.models.blocks import ConvReLU
from mcd.models.cpu_fast import fused_conv
from mcd.models.cpu_fast.ghost_conv import (
    fast_path_applies,
    group_then_point,
    lane_filled_conv,
    lane_stride,
    primary_and_ghost,
    split_depthwise,
    splits,
)
from mcd.models.ghost_conv import FastGhostConv
from mcd.models.inputs import cat_channels
from mcd.models.kernel_pool import KernelMapHead, apply_pixel_kernels
from mcd.models.position_pooling import PositionAwarePool, position_features
from mcd.sampling import frame_budget, normalise_map, shares
from tests.models.helpers import row_cfg

needs_bf16 = pytest.mark.skipif(not cpu_bf16_supported(), reason="this CPU has no native bf16")


@pytest.mark.parametrize(("cin", "cout", "groups", "stride"),
                         [(16, 8, 4, 8), (12, 8, 4, 8), (40, 20, 4, 3), (144, 24, 4, 2), (16, 24, 4, 5)])
@pytest.mark.parametrize("width", [24, 29])                    # a multiple of every stride, and not
def test_lane_filled_conv_is_the_group_conv(cin, cout, groups, stride, width):
    torch.manual_seed(cin + width)
    conv = torch.nn.Conv2d(cin, cout, 7, padding=3, groups=groups)
    x = torch.randn(2, cin, 11, width)
    with torch.no_grad():
        ref = conv(x)
        for fmt in (torch.contiguous_format, torch.channels_last):
            torch.testing.assert_close(lane_filled_conv(conv, x.contiguous(memory_format=fmt), stride), ref,
                                       rtol=1e-5, atol=1e-5)


def test_lane_stride_fills_the_lanes_of_thin_groups_only():
    assert lane_stride(4, 2, 7) > 1 and lane_stride(36, 6, 7) == 2 and lane_stride(10, 5, 7) == 3
    assert lane_stride(24, 16, 7) == 1 and lane_stride(24, 12, 7) == 1


def test_inference_mode_runs_the_fast_path_with_the_same_result():
    torch.manual_seed(0)
    block = FastGhostConv(16, 16).eval()
    x = torch.rand(1, 16, 13, 21)
    with torch.no_grad():
        ref = block(x)                                       # plain no_grad: the grouped conv itself
        assert not fast_path_applies(block.group, [x])
    with torch.inference_mode():
        fast = block(x)
        assert fast_path_applies(block.group, [x]) and not fast_path_applies(block.ghost, [x])
    torch.testing.assert_close(fast, ref, rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize(("cin", "cout", "groups"), [(16, 8, 4), (12, 8, 4), (16, 24, 4), (6, 4, 2)])
@pytest.mark.parametrize("bias", [True, False])
def test_split_depthwise_is_the_group_conv_then_the_point_conv(cin, cout, groups, bias):
    torch.manual_seed(cin + cout)
    group = torch.nn.Conv2d(cin, cout, 7, padding=3, groups=groups, bias=bias)
    point = torch.nn.Conv2d(cout, cout // 2 + 1, 1, bias=bias)
    x = torch.randn(2, cin, 9, 13) * 10
    with torch.no_grad():
        ref = point(group(x))
        for fmt in (torch.contiguous_format, torch.channels_last):
            fast = split_depthwise(x.contiguous(memory_format=fmt), group.weight, group.bias, group.groups,
                                   group.padding, point.weight, point.bias)
            torch.testing.assert_close(fast, ref, rtol=1e-5, atol=1e-4)


def test_split_depthwise_runs_for_thin_groups_on_narrow_inputs_only():
    assert splits(16, 2) and splits(12, 2) and not splits(16, 6) and not splits(48, 2)


@pytest.mark.parametrize(("split", "cout"), [((48, 16), 8), ((48, 16), 24), ((32, 32), 8), ((10, 54), 8),
                                             ((64,), 8), ((16, 16, 32), 8)])
@pytest.mark.parametrize("bias", [True, False])
def test_group_then_point_on_parts_is_the_block_on_their_concatenation(split, cout, bias):
    """Parts aligned with the groups (each part's groups run on the part: split depth-wise or lane-filled) and
    parts that a group straddles (concatenated first), against the group conv and point conv of the
    concatenation, fp32, both memory formats, an odd size."""
    torch.manual_seed(len(split) + cout)
    group = torch.nn.Conv2d(sum(split), cout, 7, padding=3, groups=4, bias=bias)
    point = torch.nn.Conv2d(cout, 12, 1, bias=bias)
    parts = [torch.randn(1, c, 11, 19) * 5 for c in split]
    with torch.no_grad():
        ref = point(group(torch.cat(parts, 1)))
    with torch.inference_mode():
        for fmt in (torch.contiguous_format, torch.channels_last):
            laid = [p.contiguous(memory_format=fmt) for p in parts]
            fast = group_then_point(group, point.weight, point.bias, laid)
            torch.testing.assert_close(fast, ref, rtol=1e-5, atol=1e-4)


@pytest.mark.parametrize("batch", [1, 2])
@pytest.mark.parametrize("size", [(11, 19), (5, 4), (1, 9)])       # borders that overlap: smaller than 7
@pytest.mark.parametrize(("split", "depth", "groups", "cout"), [((16, 7, 3), 16, 2, 20), ((10, 3), 3, 4, 8),
                                                                ((16, 4), 8, 2, 8), ((8,), 8, 2, 8)])
def test_group_then_point_with_constant_channels_is_the_block_on_the_broadcast(batch, size, split, depth,
                                                                             groups, cout):
    """The kernel-map head's first block: constant channels (the descriptor) that share the last group with
    variable ones are not convolved; a constant that fills a group of its own is broadcast. Against the group
    and point conv of the concatenation with the broadcast constant, fp32, both memory formats."""
    torch.manual_seed(batch + size[0] + depth)
    group = torch.nn.Conv2d(sum(split) + depth, cout, 7, padding=3, groups=groups)
    point = torch.nn.Conv2d(cout, 10, 1)
    parts = [torch.randn(batch, c, *size) * 3 for c in split]
    constant = torch.randn(batch, depth) * 3
    whole = torch.cat([*parts, constant[:, :, None, None].expand(-1, -1, *size)], 1)
    with torch.no_grad():
        ref = point(group(whole))
    with torch.inference_mode():
        for fmt in (torch.contiguous_format, torch.channels_last):
            laid = [p.contiguous(memory_format=fmt) for p in parts]
            fast = group_then_point(group, point.weight, point.bias, laid, constant)
            torch.testing.assert_close(fast, ref, rtol=1e-5, atol=1e-4)


def test_the_kernel_map_head_in_inference_mode_is_the_head_on_the_broadcast_descriptor():
    torch.manual_seed(2)
    head = KernelMapHead(42, [40, 40], FastGhostConv, output="rms_centred", padding="zeros").eval()
    parts = [torch.rand(1, 16, 12, 17), torch.rand(1, 7, 12, 17), torch.rand(1, 3, 12, 17) * 4]
    desc = torch.randn(1, 16)
    with torch.no_grad():
        ref = head(parts, desc)
        whole = torch.cat([*parts, desc[:, :, None, None].expand(-1, -1, 12, 17)], 1)
        torch.testing.assert_close(torch.tanh(head.scale(head.out(head.blocks(whole)))), ref)
    with torch.inference_mode():
        torch.testing.assert_close(head(parts, desc), ref, rtol=1e-4, atol=1e-4)


def test_a_fast_ghost_conv_block_on_parts_is_the_block_on_their_concatenation():
    torch.manual_seed(1)
    block = FastGhostConv(64, 16).eval()
    parts = [torch.rand(1, 48, 9, 14), torch.rand(1, 16, 9, 14)]
    with torch.no_grad():
        ref = block(torch.cat(parts, 1))
        torch.testing.assert_close(block.forward_parts(parts), ref)     # no_grad: concatenated as before
    with torch.inference_mode():
        torch.testing.assert_close(block.forward_parts(parts), ref, rtol=1e-5, atol=1e-4)


@pytest.mark.parametrize(("cin", "cout"), [(12, 16), (16, 16), (16, 48)])
def test_fast_ghost_conv_in_inference_mode_is_the_block(cin, cout):
    """Each of the block's inference paths (split depth-wise for 2 outputs per group, lane-filled otherwise)
    against the block under plain no_grad, fp32, both memory formats, an odd size."""
    torch.manual_seed(cin)
    block = FastGhostConv(cin, cout).eval()
    x = torch.rand(1, cin, 15, 23) * 5
    with torch.no_grad():
        ref = block(x)
    with torch.inference_mode():
        for fmt in (torch.contiguous_format, torch.channels_last):
            torch.testing.assert_close(block(x.contiguous(memory_format=fmt)), ref, rtol=1e-5, atol=1e-4)


@pytest.mark.parametrize("fmt", [torch.contiguous_format, torch.channels_last])
@pytest.mark.parametrize("size", [(13, 7), (1, 1)])
def test_conv_relu_block_with_fused_post_ops_is_the_block(fmt, size):
    """ConvReLU in inference mode (fused ReLU; on parts: one conv per part summed in place, the broadcast
    constant as a part) against the conv of the concatenation and a ReLU, HDR-sized inputs."""
    torch.manual_seed(size[0])
    block = ConvReLU(24, 8).eval()
    parts = [(torch.randn(2, c, *size) * 1e5).contiguous(memory_format=fmt) for c in (16, 5)]
    constant = torch.randn(2, 3)
    whole = torch.cat([*parts, constant[:, :, None, None].expand(2, 3, *size)], 1)
    with torch.no_grad():
        ref = F.relu(block.conv(whole))
    with torch.inference_mode():
        assert fused_conv.applies(block.conv.weight, parts)
        on_parts = block.forward_parts(parts, constant)
        single = block(whole.contiguous(memory_format=fmt))
    scale = float(ref.abs().max())
    torch.testing.assert_close(on_parts, ref, rtol=1e-5, atol=1e-5 * scale)
    torch.testing.assert_close(single, ref, rtol=1e-5, atol=1e-5 * scale)
    assert on_parts.is_contiguous(memory_format=fmt) and bool((on_parts >= 0).all())


def test_fused_conv_adds_in_place_and_applies_only_to_plain_cpu_inference():
    torch.manual_seed(3)
    x, w, b = torch.randn(1, 6, 9, 11), torch.randn(4, 6, 3, 3), torch.randn(4)
    acc = torch.randn(1, 4, 9, 11)
    with torch.no_grad():
        ref = F.relu(F.conv2d(x, w, b, padding=1) + acc)
        assert not fused_conv.applies(w, [x])                                 # autograd-capable mode
    with torch.inference_mode():
        out = fused_conv.conv2d(x, w, b, (1, 1), relu=True, add_to=acc)
        assert out is acc
        torch.testing.assert_close(acc, ref)
        assert not fused_conv.applies(w, [x.double()])                        # another dtype
        with pytest.raises(ValueError, match="parts have"):
            fused_conv.conv_on_parts(torch.nn.Conv2d(8, 4, 3, padding=1), [x], relu=True)
        with pytest.raises(ValueError, match="dense, stride-1"):
            fused_conv.conv_on_parts(torch.nn.Conv2d(6, 4, 3, padding=1, groups=2), [x], relu=True)


@needs_bf16
@pytest.mark.parametrize("fmt", [torch.contiguous_format, torch.channels_last])
def test_fused_conv_under_bf16_autocast_computes_what_autocast_would(fmt):
    """Autocast does not see the fused operators; they cast to its dtype as it would for a conv2d."""
    torch.manual_seed(6)
    block = ConvReLU(12, 8).eval()
    parts = [torch.randn(1, 8, 9, 13).contiguous(memory_format=fmt),            # mixed, as under autocast
             torch.randn(1, 4, 9, 13).bfloat16().contiguous(memory_format=fmt)]
    with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16):
        assert fused_conv.applies(block.conv.weight, parts)
        ref = F.relu(block.conv(torch.cat([p.bfloat16() for p in parts], 1)))
        out = block.forward_parts(parts)
    assert out.dtype == ref.dtype == torch.bfloat16
    torch.testing.assert_close(out.float(), ref.float(), rtol=2e-2, atol=2e-2 * float(ref.abs().max()))


@pytest.mark.parametrize("fmt", [torch.contiguous_format, torch.channels_last])
@pytest.mark.parametrize(("cin", "cout"), [(16, 16), (48, 24)])
def test_primary_and_ghost_is_the_block(fmt, cin, cout):
    """The whole block as one stacked point-wise conv and one depth-wise conv (identity on the primary half)
    against the block's plain form; HDR-sized inputs."""
    torch.manual_seed(cin)
    block = FastGhostConv(cin, cout).eval()
    x = (torch.randn(2, cin, 7, 10) * 1e4).contiguous(memory_format=fmt)
    with torch.no_grad():
        ref = block(x)
    with torch.inference_mode():
        out = primary_and_ghost(block.group, block.point, block.ghost, [x])
    torch.testing.assert_close(out, ref, rtol=1e-5, atol=1e-5 * float(ref.abs().max()))
    assert out.shape == ref.shape
    assert fmt != torch.channels_last or out.is_contiguous(memory_format=fmt)


def test_split_depthwise_adds_into_a_given_output():
    torch.manual_seed(5)
    group = torch.nn.Conv2d(16, 8, 7, padding=3, groups=4)
    point = torch.nn.Conv2d(8, 6, 1)
    x = torch.rand(1, 16, 9, 12)
    acc = torch.randn(1, 6, 9, 12)
    with torch.no_grad():
        ref = acc + point(group(x))
    for mode in (torch.no_grad, torch.inference_mode):                     # plain add_, fused post-op
        with mode():
            out = split_depthwise(x, group.weight, group.bias, 4, group.padding, point.weight, point.bias,
                                  acc.clone())
        torch.testing.assert_close(out, ref, rtol=1e-5, atol=1e-5)


def _eager_then_channels_last(row: str, profile: str, size: tuple[int, int], colour: float):
    """Row ``row`` (seeded), random inputs of ``size`` (colour buffers scaled by ``colour``), its output under
    plain no_grad, then the model and inputs in channels-last: ``(model, inputs, reference output)``."""
    torch.manual_seed(0)
    model = build(row_cfg(row, profile=profile)).eval()
    x = {name: torch.rand(1, 1 if name == "depth" else 3, *size) * (colour if name.startswith("c") else 1)
         for name in model.required_buffers()}
    x["ref"] = None
    with torch.no_grad():
        ref = model(x)["output"]
    cl = torch.channels_last
    return model.to(memory_format=cl), {k: v if v is None else v.contiguous(memory_format=cl)
                                        for k, v in x.items()}, ref


@pytest.mark.parametrize("row", ["A", "C", "F"])
def test_a_rows_fp32_inference_paths_are_its_eager_forward(row):
    """Every fp32 fast path of a row at once (inference mode, channels-last) against its forward under plain
    no_grad: row A (ConvReLU blocks), C (KP without FG: the kernel-map head's ConvReLU on parts with the
    descriptor), F (Fast GhostConv, PP, SA)."""
    fast_model, xl, ref = _eager_then_channels_last(row, "paper", (37, 53), colour=1e3)
    with torch.inference_mode():
        fast = fast_model(xl)["output"]
    torch.testing.assert_close(fast, ref, rtol=1e-4, atol=1e-4 * float(ref.abs().max()))


def test_a_concatenation_with_one_channel_inputs_stays_channels_last_without_gradients():
    cl = torch.channels_last
    rgb = torch.rand(1, 3, 5, 7).contiguous(memory_format=cl)
    parts = [torch.rand(1, 1, 5, 7), rgb, torch.rand(1, 2, 5, 7).bfloat16()]
    assert not torch.cat(parts, 1).is_contiguous(memory_format=cl)          # what torch.cat does
    with torch.inference_mode():
        out = cat_channels(parts)
    assert out.is_contiguous(memory_format=cl) and out.dtype == torch.float32
    torch.testing.assert_close(out, torch.cat(parts, 1))
    grad = cat_channels([rgb.requires_grad_(), parts[0]])                  # autograd: torch.cat itself
    assert grad.requires_grad


def _unfold_kernels(image: torch.Tensor, kernels: torch.Tensor) -> torch.Tensor:
    """Reference: unfold the replicate-padded image and take each pixel's weighted sum of its 25 taps."""
    b, c, h, w = image.shape
    cols = F.unfold(F.pad(image, (2, 2, 2, 2), mode="replicate"), 5).view(b, c, 25, h, w)
    return (cols * kernels[:, None]).sum(2)


def test_in_place_kernel_application_matches_unfold_in_value_and_gradient():
    torch.manual_seed(0)
    image = (torch.rand(2, 3, 9, 14) * 50).requires_grad_()
    kernels = torch.softmax(torch.randn(2, 25, 9, 14), 1).requires_grad_()
    fast, ref = apply_pixel_kernels(image, kernels), _unfold_kernels(image, kernels)
    torch.testing.assert_close(fast, ref)
    g = torch.randn_like(ref)
    grads_fast = torch.autograd.grad(fast, (image, kernels), g)
    grads_ref = torch.autograd.grad(ref, (image, kernels), g)
    for a, b in zip(grads_fast, grads_ref, strict=True):
        torch.testing.assert_close(a, b)


def _pp_reference(pool: PositionAwarePool, x: torch.Tensor) -> torch.Tensor:
    """Reference: concatenate features and positions, score, pixel-unshuffle the members, weighted sum."""
    h, w = x.shape[-2:]
    if h % 2 or w % 2:
        x = F.pad(x, (0, w % 2, 0, h % 2), mode="replicate")
    b, c, h, w = x.shape
    pos = position_features(h, w, x).expand(b, -1, -1, -1)
    scores = F.pixel_unshuffle(pool.score(torch.cat([x, pos], 1)), 2)
    weights = torch.softmax(scores.float(), dim=1).to(x.dtype)
    return (F.pixel_unshuffle(x, 2).view(b, c, 4, h // 2, w // 2) * weights[:, None]).sum(2)


@pytest.mark.parametrize("hidden", [0, 8])
@pytest.mark.parametrize("size", [(12, 18), (13, 7)])
def test_position_aware_pooling_matches_the_concatenating_reference(hidden, size):
    torch.manual_seed(hidden)
    pool = PositionAwarePool(16, hidden=hidden)
    x = torch.randn(2, 16, *size, requires_grad=True)
    fast, ref = pool(x), _pp_reference(pool, x)
    torch.testing.assert_close(fast, ref)
    torch.testing.assert_close(torch.autograd.grad(fast.sum(), x)[0], torch.autograd.grad(ref.sum(), x)[0])


@needs_bf16
def test_position_aware_pooling_in_bf16_stays_near_fp32():
    torch.manual_seed(0)
    pool = PositionAwarePool(32).to(memory_format=torch.channels_last)
    x = torch.randn(1, 32, 40, 64).contiguous(memory_format=torch.channels_last)
    with torch.inference_mode():
        ref = _pp_reference(pool, x)
        with torch.autocast("cpu", dtype=torch.bfloat16):
            fast = pool(x.bfloat16())
    assert float((fast.float() - ref).abs().max()) < 0.05 * float(ref.abs().max())


def _normalise_reference(p: torch.Tensor, budget: float, cap: int) -> torch.Tensor:
    """Reference: water level from the sorted shares, largest remainders by a full sort (the implementation
    before the sort-free one)."""
    b = p.shape[0]
    flat = p.reshape(b, -1).double()
    n = flat.shape[1]
    total = frame_budget(n, budget)
    flat = flat / flat.sum(1, keepdim=True)
    flat = (1 - 1e-6) * flat + 1e-6 / n
    ps, _ = flat.sort(dim=1, descending=True)
    rest = ps.flip(1).cumsum(1).flip(1)
    k = torch.arange(n, dtype=flat.dtype)
    first = ((total - k * cap) * ps <= cap * rest).double().argmax(dim=1)
    lam = (total - first.double() * cap) / rest.gather(1, first[:, None]).squeeze(1)
    raw = torch.minimum(lam[:, None] * flat, torch.full_like(flat, cap))
    floor = raw.floor()
    deficit = (total - floor.sum(1)).round().long()
    remainder = torch.where(floor >= cap, torch.full_like(raw, -1.0), raw - floor)
    order = remainder.argsort(dim=1, descending=True, stable=True)        # ties to the lower index
    rank = torch.empty_like(order)
    rank.scatter_(1, order, torch.arange(n).expand(b, n))
    return (floor + (rank < deficit[:, None]).double()).reshape(p.shape)


@pytest.mark.parametrize("scale", [0.5, 3.0, 8.0])
@pytest.mark.parametrize("budget", [2, 4, 16.5])
def test_sort_free_normalisation_equals_the_sorting_reference(scale, budget):
    torch.manual_seed(int(scale * 10) + int(budget))
    p = shares(torch.randn(2, 1, 37, 53) * scale)
    m = normalise_map(p, budget)
    assert torch.equal(m.double(), _normalise_reference(p, budget, 63))


def test_a_long_capping_cascade_reaches_the_same_water_level():
    """Geometric shares: each pixel capped pushes the next over the cap, one more per pass."""
    p = (0.5 ** torch.arange(40, dtype=torch.float64) + 1e-3).view(1, 1, 5, 8)
    p = p / p.sum()
    m = normalise_map(p, 30)
    assert torch.equal(m.double(), _normalise_reference(p, 30, 63))
    assert int((m == 63).sum()) >= 5


@needs_bf16
@pytest.mark.parametrize(("row", "profile"), [("F", "paper"), ("A", "paper"), ("F", "cpu")])
def test_fastest_cpu_path_of_a_row_stays_near_fp32_eager(row, profile):
    """The bench's fastest CPU path (inference mode, bf16 autocast, channels-last, every fast path) against
    the fp32 eager forward under plain no_grad (grouped convs as they are)."""
    fast_model, xl, ref = _eager_then_channels_last(row, profile, (48, 80), colour=20)
    with torch.inference_mode():
        fp32 = fast_model(xl)["output"]
        with torch.autocast("cpu", dtype=torch.bfloat16):
            fast = fast_model(xl)["output"]
    torch.testing.assert_close(fp32, ref, rtol=1e-4, atol=1e-4)         # fast paths, same precision
    rel = float(((fast - ref).abs() / (ref.abs() + 1)).mean())
    assert torch.isfinite(fast).all() and rel < 0.02, rel

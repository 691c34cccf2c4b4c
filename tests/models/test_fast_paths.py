"""The fast paths of mcd/models/fast_paths.py against their reference formulations (docs/inference.md "Fast
paths"): the kernel application in the kernels' layout, semantic alignment's attention in the autocast dtype,
channels-last G-buffers and block inputs, the replicate-padded Fast GhostConv block (inference and training),
the kernel-map head's replicate-padded last convolution, the output bound's selections and window maxima (bit
for bit, on rendered frames and on HDR, black, odd-sized and non-finite ones); each on its own, and the
bundled row F (both bundles: zero and replicate padding in ``F_s``) on rendered Cornell-box frames (fp32
within 1e-4 relative of the reference; bf16 within 0.1 dB PSNR of fp32 against the rendered reference;
training gradients within 1e-4 relative)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mcd.core.metrics import psnr
from mcd.denoise.weights import load
from mcd.lit.precision import cpu_bf16_supported
from mcd.models import fast_paths, ghost_conv
from mcd.models.cpu_fast import ghost_conv as cpu_ghost
from mcd.models.cpu_fast.replicate import replicate_conv, replicate_conv_applies
from mcd.models.ghost_conv import FastGhostConv
from mcd.models.inputs import gbuffers
from mcd.models.kernel_pool import KernelPool, apply_pixel_kernels, filter_below, interpolate_kernels
from mcd.models.latency import model_inputs
from mcd.models.output_bound import clamp_output, output_bound, quantile, window_max
from mcd.models.semantic_alignment import SemanticAlignment

needs_bf16 = pytest.mark.skipif(not cpu_bf16_supported(), reason="this CPU has no native bf16")
CL = torch.channels_last


def _kernels(size: tuple[int, int], seed: int = 0) -> torch.Tensor:
    torch.manual_seed(seed)
    pool = KernelPool.normalised(torch.randn(1, 128, 25) * 3)
    return interpolate_kernels(pool, torch.tanh(torch.randn(1, 2, *size) * 2))


@pytest.mark.parametrize("layout", [CL, torch.contiguous_format])
@pytest.mark.parametrize("size", [(37, 53), (8, 8)])
def test_kernel_application_in_the_kernels_layout_is_the_reference(layout, size):
    kernels = _kernels(size)
    image = torch.rand(1, 3, *size) * torch.logspace(-3, 5, size[1])      # HDR up to 1e5, and exact zeros
    image[..., : size[0] // 2, :] = 0
    image = image.contiguous(memory_format=layout)
    fast = apply_pixel_kernels(image, kernels)
    with fast_paths.reference():
        ref = apply_pixel_kernels(image, kernels)
    assert torch.equal(fast, ref)
    assert fast.is_contiguous(memory_format=layout)                       # handed back in the image's layout
    hits = torch.rand(1, 1, *size) > 0.3
    fast = filter_below(image, kernels, 4.0, hits)
    with fast_paths.reference():
        torch.testing.assert_close(fast, filter_below(image, kernels, 4.0, hits), rtol=1e-6, atol=0)


def test_gbuffers_stay_channels_last_in_inference():
    x = {"depth": torch.rand(1, 1, 9, 11), "normal": torch.rand(1, 3, 9, 11).contiguous(memory_format=CL),
         "albedo": torch.rand(1, 3, 9, 11).contiguous(memory_format=CL)}
    with torch.inference_mode():
        g = gbuffers(x, "test")
    assert g.is_contiguous(memory_format=CL)
    torch.testing.assert_close(g, torch.cat([torch.log1p(x["depth"]), x["normal"], x["albedo"]], 1))


@needs_bf16
def test_semantic_alignment_in_bf16_stays_near_its_fp32_reference():
    torch.manual_seed(0)
    sa = SemanticAlignment(64, heads=4).eval().to(memory_format=CL)
    frames = [torch.randn(1, 64, 17, 23).contiguous(memory_format=CL) for _ in range(2)]

    def run() -> list[torch.Tensor]:
        sa.reset()
        with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16):
            return [sa(f).float() for f in frames]                        # the second attends to the first

    outs = {"fast": run()}
    with fast_paths.reference():
        outs["reference"] = run()
    for fast, ref in zip(outs["fast"], outs["reference"], strict=True):
        assert not torch.equal(fast, ref)                                 # the fast path ran in bf16
        rel = float((fast - ref).norm() / ref.norm())
        assert rel < 2e-2, rel


def _frames(cbox_store, model) -> list[dict[str, np.ndarray]]:
    _, store = cbox_store
    names = set(model.required_buffers()) | {"ref"}
    return [{n: store.load("cbox", frame, n) for n in sorted(names)} for frame in (9, 10, 11)]


def _outputs(model, frames, dtype: torch.dtype | None) -> list[torch.Tensor]:
    model.reset()
    outs = []
    for buffers in frames:
        x = model_inputs(model, {k: v for k, v in buffers.items() if k != "ref"}, torch.device("cpu"), True)
        with torch.inference_mode(), torch.autocast("cpu", dtype=dtype or torch.bfloat16,
                                                    enabled=dtype is not None):
            outs.append(model(x)["output"].float())
    return outs


def _display(t: torch.Tensor) -> np.ndarray:
    return t[0].permute(1, 2, 0).numpy()


#: The bundled row F checkpoints: ``F-cpu-small`` pads ``F_s`` with zeros, ``F-cpu-bundle`` with replicate
#: (``method.sampler_padding``), so each Fast GhostConv fast path runs on real frames.
BUNDLES = ("F-cpu-small", "F-cpu-bundle")


@pytest.fixture(scope="module", params=BUNDLES)
def bundled_f(request):
    return load(request.param).model.eval().to(memory_format=CL)


def test_row_f_fp32_fast_paths_are_the_reference_on_rendered_frames(cbox_store, bundled_f):
    frames = _frames(cbox_store, bundled_f)
    fast = _outputs(bundled_f, frames, None)
    with fast_paths.reference():
        ref = _outputs(bundled_f, frames, None)
    for f, r in zip(fast, ref, strict=True):
        assert torch.isfinite(f).all()
        torch.testing.assert_close(f, r, rtol=1e-4, atol=1e-4 * float(r.abs().max()))


def test_row_f_fp32_fast_paths_on_an_all_black_frame(cbox_store, bundled_f):
    frames = [{k: np.zeros_like(v) if k.startswith("c") else v for k, v in f.items()}
              for f in _frames(cbox_store, bundled_f)[:2]]
    fast = _outputs(bundled_f, frames, None)
    with fast_paths.reference():
        ref = _outputs(bundled_f, frames, None)
    for f, r in zip(fast, ref, strict=True):
        assert torch.isfinite(f).all()
        torch.testing.assert_close(f, r, rtol=1e-4, atol=1e-6)


@needs_bf16
def test_row_f_bf16_fast_paths_within_a_tenth_of_a_db_of_fp32(cbox_store, bundled_f):
    frames = _frames(cbox_store, bundled_f)
    with fast_paths.reference():
        fp32 = _outputs(bundled_f, frames, None)
    bf16 = _outputs(bundled_f, frames, torch.bfloat16)
    for f, b, buffers in zip(fp32, bf16, frames, strict=True):
        ref = buffers["ref"]
        fast_db, fp32_db = psnr(_display(b), ref), psnr(_display(f), ref)
        assert abs(fast_db - fp32_db) <= 0.1, (fast_db, fp32_db)


#: Fast GhostConv blocks of row F (``capacity=paper`` and ``cpu``): input parts, constant channels, in, out,
#: groups. The decoder blocks read two parts, the kernel-map head's first block three and a descriptor.
GHOST_BLOCKS = [([12], 0, 12, 16, 4), ([96, 48], 0, 144, 48, 4), ([48, 16], 0, 64, 16, 4),
                ([16, 7, 3], 16, 42, 40, 2), ([8, 7, 3], 16, 34, 4, 2), ([96], 0, 96, 96, 4)]


def _ghost_inputs(widths, depth, batch, size, seed=0):
    torch.manual_seed(seed)
    parts = [(torch.rand(batch, c, *size) * torch.logspace(-3, 5, size[1])).contiguous(memory_format=CL)
             for c in widths]                                             # HDR up to 1e5
    parts[0][..., : size[0] // 3, :] = 0                                  # and exact zeros
    return parts, (torch.randn(batch, depth) if depth else None)


@pytest.mark.parametrize("merged", [True, False])
@pytest.mark.parametrize("size", [(37, 53), (1, 9), (5, 4)])
@pytest.mark.parametrize("block", GHOST_BLOCKS)
def test_replicate_ghost_block_in_inference_is_the_reference(monkeypatch, block, size, merged):
    widths, depth, cin, cout, groups = block
    ghost = FastGhostConv(cin, cout, 7, groups, padding="replicate").eval().to(memory_format=CL)
    monkeypatch.setattr(cpu_ghost, "merged_pays", lambda *args: merged)       # both forms of p
    for batch in (1, 2):
        parts, constant = _ghost_inputs(widths, depth, batch, size)
        with torch.inference_mode():
            assert cpu_ghost.replicate_path_applies(ghost.group, ghost.ghost, parts)
            fast = ghost.forward_parts(parts, constant)
            with fast_paths.reference():
                ref = ghost.forward_parts(parts, constant)
        assert fast.is_contiguous(memory_format=CL)
        torch.testing.assert_close(fast, ref, rtol=1e-4, atol=1e-4 * float(ref.abs().max()))


@needs_bf16
@pytest.mark.parametrize("block", GHOST_BLOCKS)
def test_replicate_ghost_block_in_bf16_stays_near_fp32(block):
    widths, depth, cin, cout, groups = block
    ghost = FastGhostConv(cin, cout, 7, groups, padding="replicate").eval().to(memory_format=CL)
    parts, constant = _ghost_inputs(widths, depth, 1, (37, 53))
    with torch.inference_mode():
        with fast_paths.reference():
            ref = ghost.forward_parts(parts, constant)
        with torch.autocast("cpu", dtype=torch.bfloat16):
            fast = ghost.forward_parts(parts, constant).float()
    rel = float((fast - ref).norm() / ref.norm())
    assert rel < 1e-2, rel


@pytest.mark.parametrize("padding", ["replicate", "zeros"])
def test_merged_ghost_block_in_training_has_the_reference_gradients(padding):
    ghost = FastGhostConv(42, 40, 7, 2, padding=padding).train()
    parts, constant = _ghost_inputs([42], 0, 4, (23, 19))

    def step():
        ghost.zero_grad()
        x = parts[0].clone().requires_grad_()
        y = ghost(x)
        (y * torch.linspace(-1, 1, y.numel()).view_as(y)).sum().backward()
        return [y.detach(), x.grad, *(p.grad.clone() for p in ghost.parameters())]

    assert cpu_ghost.merged_applies(ghost.group, parts[0])
    fast = step()
    with fast_paths.reference():
        ref = step()
    for f, r in zip(fast, ref, strict=True):
        torch.testing.assert_close(f, r, rtol=1e-4, atol=1e-4 * float(r.abs().max()))


def test_row_f_training_gradients_are_the_reference_on_rendered_frames(cbox_store, monkeypatch):
    """Row F's training step with the merged Ghost convs against the same step without them (the other fast
    paths run in both, so that what differs is this path)."""
    model = load("F-cpu-bundle").model.train()
    frame = _frames(cbox_store, model)[0]
    x = model_inputs(model, frame, torch.device("cpu"), False)
    x["ref"] = torch.from_numpy(np.ascontiguousarray(frame["ref"])).permute(2, 0, 1)[None]
    x = {k: None if v is None else torch.cat([v, v.flip(-1)]) for k, v in x.items()}        # a batch of 2

    def step():
        model.zero_grad()
        model.reset()
        torch.manual_seed(0)
        out = model(x)["output"]
        (out - x["ref"]).abs().mean().backward()
        return {"output": out.detach(), **{n: p.grad.clone() for n, p in model.named_parameters()
                                           if p.grad is not None}}

    fast = step()
    monkeypatch.setattr(ghost_conv, "merged_applies", lambda *args: False)
    ref = step()
    assert fast.keys() == ref.keys() and len(ref) > 20
    # The kernel-map head's and the kernel pool's gradients are left out: they reach them through the adaptive
    # render's whole-sample allocation, which a logit 1e-6 away can move by a sample (their gradients then
    # differ by up to 15% while the output agrees to 5e-6); the head's blocks on their own are compared in
    # test_merged_ghost_block_in_training_has_the_reference_gradients. Together, the other gradients within
    # 1e-4 relative (norm); each tensor within 1e-3 of its own norm or 1e-6 of theirs: the smallest (blocks
    # behind dead ReLUs, 1e-9 against 0.24) are sums of cancelling terms whose fp32 rounding differs between
    # the merged conv and the two.
    out = ref.pop("output")
    torch.testing.assert_close(fast.pop("output"), out, rtol=1e-4, atol=1e-4 * float(out.abs().max()))
    names = [n for n in ref if not n.startswith(("sampler.head.", "sampler.pool."))]
    flat = [torch.cat([d[n].flatten() for n in names]) for d in (fast, ref)]
    whole = float(flat[1].norm())
    assert float((flat[0] - flat[1]).norm()) <= 1e-4 * whole
    for name in names:
        bound = max(1e-3 * float(ref[name].norm()), 1e-6 * whole)
        assert float((fast[name] - ref[name]).norm()) <= bound, name


def _bound_cases(cbox_store) -> list[tuple[torch.Tensor, torch.Tensor]]:
    """(render, output) pairs: the rendered cbox frames' 4-spp colour against their reference (batch 1 and
    2), the same with 1e5 fireflies and a black band, all black, odd sizes, and an output with NaN and Inf."""
    _, store = cbox_store
    load = [(torch.from_numpy(np.ascontiguousarray(store.load("cbox", f, n))).permute(2, 0, 1)[None])
            for f in (9, 10) for n in ("c4", "ref")]
    renders, outputs = torch.cat(load[0::2]), torch.cat(load[1::2])
    hot = renders.clone()
    hot[..., 3, 5], hot[..., 17, 22], hot[..., :4, :] = 1e5, 1e5, 0
    torch.manual_seed(0)
    odd = [(torch.rand(1, 3, *s) * torch.logspace(-3, 5, s[1]), torch.rand(1, 3, *s) * 1e3)
           for s in ((1, 1), (1, 9), (5, 4), (37, 53))]
    bad = outputs[:1].clone()
    bad[..., 0, 0], bad[..., 5, 7], bad[..., 9, 2] = float("nan"), float("inf"), float("-inf")
    return [(renders[:1], outputs[:1]), (renders, outputs), (hot, outputs), (torch.zeros_like(renders),
            torch.zeros_like(outputs)), *odd, (renders[:1], bad)]


def test_output_bound_fast_path_is_the_reference_bit_for_bit(cbox_store):
    for render, output in _bound_cases(cbox_store):
        for layout in (CL, torch.contiguous_format):
            render, output = render.contiguous(memory_format=layout), output.contiguous(memory_format=layout)
            with torch.inference_mode():
                fast = output_bound(render), clamp_output(output, render)
                with fast_paths.reference():
                    ref = output_bound(render), clamp_output(output, render)
            for f, r in zip(fast, ref, strict=True):
                assert torch.equal(f, r), tuple(render.shape)


@pytest.mark.parametrize("size", [1, 3, 7, 9])
def test_window_max_and_quantile_are_the_reference(size):
    torch.manual_seed(size)
    for shape in ((1, 1, 1, 1), (2, 1, 5, 4), (1, 1, 37, 53)):
        m = torch.rand(shape) * 10
        m[..., ::3] = 0                                                   # repeated values: ties
        ref = torch.nn.functional.max_pool2d(m, size, stride=1, padding=size // 2)
        assert torch.equal(window_max(m, size), ref)
        flat = m.flatten(1)
        for q in (0.0, 0.5, 0.99, 1.0):
            assert torch.equal(quantile(flat, q), torch.quantile(flat, q, dim=1))


@pytest.mark.parametrize("size", [(37, 53), (1, 9), (5, 4)])
def test_replicate_conv_in_inference_is_the_reference(size):
    """The kernel-map head's last convolution (40 -> 2, 3x3, replicate) on HDR inputs with exact zeros."""
    torch.manual_seed(0)
    conv = torch.nn.Conv2d(40, 2, 3, padding=1, padding_mode="replicate").to(memory_format=CL)
    parts, _ = _ghost_inputs([40], 0, 2, size)
    with torch.inference_mode():
        assert replicate_conv_applies(conv, parts[0])
        fast, ref = replicate_conv(conv, parts[0]), conv(parts[0])
    torch.testing.assert_close(fast, ref, rtol=1e-4, atol=1e-4 * float(ref.abs().max()))

"""The training step's fast paths (notes/f_speed.md "The training step") against the code they replace, bit
for bit: the kernel application's written-out backward (:class:`mcd.models.kernel_pool.PixelKernels`, against
autograd's backward of its multiply-adds) and a convolution's input replicate-padded in its own dtype with
``F.pad``'s gradient (:func:`mcd.models.cpu_fast.replicate.replicate_pad`, against ``F.pad`` under autocast)
with its backward summed on the ring (against ATen's kernel), the decoders' upsampling with its backward in
channels-last (:func:`mcd.models.cpu_fast.upsample.upsample_bilinear`, against ``F.interpolate``);
each on the rendered cbox frames (HDR, with 1e5 fireflies and a black band), all-black frames and odd sizes,
in both layouts, in fp32 and under bf16 autocast; then row F's training step on rendered frames, output and
every gradient."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
import torch
import torch.nn.functional as F
from torch import nn

from mcd.models import fast_paths, kernel_pool
from mcd.models.cpu_fast import replicate, upsample
from mcd.models.cpu_fast.replicate import padded_conv, replicate_pad
from mcd.models.kernel_pool import KernelPool, apply_pixel_kernels, filter_below, interpolate_kernels
from mcd.models.latency import model_inputs

CL = torch.channels_last
LAYOUTS = (CL, torch.contiguous_format)


def _images(cbox_store) -> list[torch.Tensor]:
    """The rendered cbox frames' 4-spp colour (batch 2), the same with 1e5 fireflies and a black band, all
    black, and odd sizes with values from 1e-3 to 1e5 and exact zeros."""
    _, store = cbox_store
    frames = [np.ascontiguousarray(store.load("cbox", f, "c4")) for f in (9, 10)]
    renders = torch.cat([torch.from_numpy(f).permute(2, 0, 1)[None] for f in frames])
    hot = renders.clone()
    hot[..., 3, 5], hot[..., 17, 22], hot[..., :4, :] = 1e5, 1e5, 0
    torch.manual_seed(0)
    odd = []
    for size in ((1, 9), (5, 4), (37, 53)):
        image = torch.rand(1, 3, *size) * torch.logspace(-3, 5, size[1])
        image[..., : size[0] // 2, :] = 0
        odd.append(image)
    return [renders, hot, torch.zeros_like(renders), *odd]


def _kernels(image: torch.Tensor, seed: int) -> torch.Tensor:
    torch.manual_seed(seed)
    b, _, h, w = image.shape
    pool = KernelPool.normalised(torch.randn(b, 128, 25) * 3)
    return interpolate_kernels(pool, torch.tanh(torch.randn(b, 2, h, w) * 2))


def _filtered(which: str, image: torch.Tensor, kernels: torch.Tensor) -> torch.Tensor:
    if which == "apply":
        return apply_pixel_kernels(image, kernels)
    if which == "below":
        return filter_below(image, kernels, 0.69)
    hits = image.amax(1, keepdim=True) > 0.05
    return filter_below(image, kernels, 0.69, hits)


def _kernel_step(which: str, image: torch.Tensor, kernels: torch.Tensor) -> list[torch.Tensor]:
    x, k = image.clone().requires_grad_(), kernels.clone().requires_grad_()
    out = _filtered(which, x, k)
    torch.manual_seed(1)
    out.backward(torch.randn_like(out))
    return [out.detach(), x.grad, k.grad]


@pytest.mark.parametrize("which", ["apply", "below", "hits"])
def test_kernel_application_backward_is_autograds_bit_for_bit(cbox_store, monkeypatch, which):
    for i, image in enumerate(_images(cbox_store)):
        for layout in LAYOUTS:
            x = image.contiguous(memory_format=layout)
            kernels = _kernels(image, i).contiguous(memory_format=layout)
            fast = _kernel_step(which, x, kernels)
            with monkeypatch.context() as m:  # the code before: autograd through the multiply-adds
                m.setattr(kernel_pool.PixelKernels, "apply", kernel_pool.pixel_kernel_passes)
                ref = _kernel_step(which, x, kernels)
            for f, r in zip(fast, ref, strict=True):
                assert torch.equal(f, r), (which, tuple(image.shape), layout)


def _conv_step(x: torch.Tensor, weight: torch.Tensor, padding: int, half: bool) -> list[torch.Tensor]:
    x = x.clone().requires_grad_()
    with torch.autocast("cpu", dtype=torch.bfloat16, enabled=half):
        y = F.conv2d(replicate_pad(x, (padding,) * 4), weight)
    torch.manual_seed(2)
    y.backward(torch.randn_like(y))
    with torch.no_grad(), torch.autocast("cpu", dtype=torch.bfloat16, enabled=half):
        plain = F.conv2d(replicate_pad(x, (padding,) * 4), weight)
    return [y.detach(), plain, x.grad]


@pytest.mark.parametrize("padding", [1, 2, 3])
@pytest.mark.parametrize("dtype", ["fp32", "fp32-autocast", "bf16-autocast"])
def test_replicate_pad_is_f_pad_bit_for_bit(cbox_store, dtype, padding):
    half = dtype.endswith("autocast")
    for image in _images(cbox_store):
        torch.manual_seed(3)
        features = torch.cat([image, torch.log1p(image), image.amax(1, keepdim=True)], 1)   # 7 channels
        x = features.to(torch.bfloat16 if dtype == "bf16-autocast" else torch.float32)
        weight = torch.randn(4, 7, 2 * padding + 1, 2 * padding + 1)
        for layout in LAYOUTS:
            x, weight = x.contiguous(memory_format=layout), weight.contiguous(memory_format=layout)
            fast = _conv_step(x, weight, padding, half)
            with fast_paths.reference():
                ref = _conv_step(x, weight, padding, half)
            for f, r in zip(fast, ref, strict=True):
                assert f.dtype == r.dtype and torch.equal(f, r), (dtype, tuple(x.shape), layout)


@pytest.mark.parametrize("groups", [1, 4])
@pytest.mark.parametrize("mode", ["replicate", "zeros"])
def test_padded_conv_is_nn_conv2d(mode, groups):
    torch.manual_seed(4)
    conv = nn.Conv2d(8, 8, 3, padding=1, groups=groups, padding_mode=mode).to(memory_format=CL)
    x = (torch.rand(2, 8, 5, 9) * 1e5).contiguous(memory_format=CL)
    outs = []
    for run in (padded_conv, lambda c, t: c(t)):
        conv.zero_grad()
        t = x.clone().requires_grad_()
        with torch.autocast("cpu", dtype=torch.bfloat16):
            y = run(conv, t)
        y.float().square().mean().backward()
        outs.append([y.detach(), t.grad, *(p.grad.clone() for p in conv.parameters())])
    for f, r in zip(*outs, strict=True):
        assert torch.equal(f, r)


@pytest.mark.parametrize("half", [False, True])
def test_row_f_training_step_is_the_code_before_bit_for_bit(cbox_store, monkeypatch, half):
    """Row F (``capacity=cpu``, channels-last, as the scaling study trains it) on a clip of three rendered
    frames: the first without gradient (it only carries semantic alignment's state), the last two with;
    the output and every parameter's gradient with the training paths and without them."""
    from mcd.config.compose import compose
    from mcd.models import build

    torch.manual_seed(0)
    model = build(compose(["+experiment=F"])).train().to(memory_format=CL)
    _, store = cbox_store
    names = set(model.required_buffers()) | {"ref"}
    clip = []
    for f in (9, 10, 11):
        buffers = {n: store.load("cbox", f, n) for n in sorted(names)}
        x = model_inputs(model, {k: v for k, v in buffers.items() if k != "ref"}, torch.device("cpu"), True)
        x["ref"] = torch.from_numpy(np.ascontiguousarray(buffers["ref"])).permute(2, 0, 1)[None]
        clip.append({k: None if v is None else torch.cat([v, v.flip(-1)]) for k, v in x.items()})  # batch 2

    def step() -> dict[str, torch.Tensor]:
        model.zero_grad(set_to_none=True)
        model.reset()
        outs = []
        with torch.autocast("cpu", dtype=torch.bfloat16, enabled=half):
            for t, x in enumerate(clip):
                with torch.set_grad_enabled(t > 0):
                    outs.append(model(x)["output"])
        out = torch.stack(outs[1:], 1).float()
        (out - torch.stack([x["ref"] for x in clip[1:]], 1)).abs().mean().backward()
        return {"output": out.detach(), **{n: p.grad.clone() for n, p in model.named_parameters()
                                           if p.grad is not None}}

    fast = step()
    monkeypatch.setattr(kernel_pool.PixelKernels, "apply", kernel_pool.pixel_kernel_passes)
    monkeypatch.setattr(replicate, "fast_paths", SimpleNamespace(enabled=lambda: False))
    monkeypatch.setattr(upsample, "fast_paths", SimpleNamespace(enabled=lambda: False))
    ref = step()
    assert fast.keys() == ref.keys() and len(ref) > 50
    for name in ref:
        assert torch.equal(fast[name], ref[name]), name


@pytest.mark.parametrize("dtype", [torch.bfloat16, torch.float32])
@pytest.mark.parametrize("layout", LAYOUTS)
def test_ring_sums_are_atens_pad_backward_bit_for_bit(cbox_store, dtype, layout):
    """The gradient of a replicate pad summed on the input's ring (fp32 sums of a bf16 gradient, as under
    autocast), against ATen's kernel: every bit, negative zeros and strides included; rendered frames with
    fireflies, all black, and odd sizes down to 2 x 2."""
    from mcd.models.cpu_fast.replicate import ring_sums, ring_sums_apply

    bits = torch.int16 if dtype == torch.bfloat16 else torch.int32
    shapes = [tuple(image.shape) for image in _images(cbox_store)] + [(2, 3, 2, 2), (1, 4, 2, 7)]
    for i, shape in enumerate(shapes):
        for p in (1, 2, 3, 4):
            torch.manual_seed(i * 10 + p)
            h, w = shape[-2:]
            grad = torch.randn(*shape[:2], h + 2 * p, w + 2 * p) * torch.logspace(-4, 5, w + 2 * p)
            grad = grad.to(dtype)
            grad[..., 0, 0], grad[..., p + 1, p + 1] = -0.0, -0.0
            grad = grad.contiguous(memory_format=layout)
            if not ring_sums_apply(grad, shape, [p] * 4, dtype):
                assert min(h, w) < 2
                continue
            like = torch.empty(shape, dtype=torch.float32, memory_format=layout)
            ref = torch.ops.aten.replication_pad2d_backward(grad.float(), like, [p] * 4).to(dtype)
            got = ring_sums(grad, shape, [p] * 4, torch.float32, layout)
            assert got.stride() == ref.stride(), (shape, p)
            assert torch.equal(got.contiguous().view(bits), ref.contiguous().view(bits)), (shape, p)


@pytest.mark.parametrize("dtype", [torch.bfloat16, torch.float32])
@pytest.mark.parametrize("layout", LAYOUTS)
def test_upsample_backward_is_autograds_bit_for_bit(cbox_store, dtype, layout):
    """The decoder's bilinear upsampling (:func:`mcd.models.cpu_fast.upsample.upsample_bilinear`) with its
    gradient arriving as a channel slice of a concatenation's (as in a U-Net decoder) or whole, against
    ``F.interpolate`` and autograd: output and gradient, every bit; rendered frames with fireflies, all black,
    odd sizes (up to odd output sizes)."""
    from mcd.models.cpu_fast.upsample import upsample_bilinear

    bits = torch.int16 if dtype == torch.bfloat16 else torch.int32
    for image in _images(cbox_store):
        features = torch.cat([image, torch.log1p(image)], 1).to(dtype).contiguous(memory_format=layout)
        h, w = features.shape[-2:]
        for size in ((2 * h, 2 * w), (2 * h + 1, 2 * w - 1)):
            fast = _upsample_step(features, lambda x, size=size: upsample_bilinear(x, size))
            ref = _upsample_step(features, lambda x, size=size: F.interpolate(x, size=size, mode="bilinear",
                                                                              align_corners=False))
            where = (tuple(features.shape), size)
            for f, r in zip(fast, ref, strict=True):
                assert f.stride() == r.stride(), where
                assert torch.equal(f.contiguous().view(bits), r.contiguous().view(bits)), where


def _upsample_step(features: torch.Tensor, up) -> list[torch.Tensor]:  # noqa: ANN001
    """``up(features)`` and its gradient, the gradient arriving through a concatenation with a skip."""
    x = features.clone().requires_grad_()
    y = up(x)
    z = torch.cat([y, torch.ones_like(y[:, :2])], 1)
    torch.manual_seed(5)
    z.backward(torch.randn_like(z) * 1e3)
    return [y.detach(), x.grad]


@pytest.mark.parametrize("half", [False, True])
def test_row_f_clip_with_advance_is_the_whole_forward_bit_for_bit(cbox_store, monkeypatch, half):
    """``DenoiseModule.run_clip`` on a training clip of five rendered frames (batch 2): the three frames whose
    output the loss does not read go through ``TwoStage.advance`` (``F_d``'s encoder only), against the
    whole forward for them; the two outputs, the loss and every parameter's gradient, bit for bit. Also
    ``advance`` outside training runs the whole forward (the output steps' hook included)."""
    from mcd.config.compose import compose
    from mcd.lit.module import DenoiseModule
    from mcd.losses import build_loss
    from mcd.models import build
    from mcd.models.two_stage import TwoStage

    cfg = compose(["+experiment=F"])
    torch.manual_seed(0)
    model = build(cfg).train().to(memory_format=CL)
    module = DenoiseModule(cfg, model, build_loss(cfg))
    _, store = cbox_store
    names = sorted(set(model.required_buffers()) | {"ref"})
    batch = {}
    for n in names:
        frames = [torch.from_numpy(np.ascontiguousarray(store.load("cbox", f, n))).permute(2, 0, 1)
                  for f in range(5, 10)]
        clip = torch.stack(frames)[None]
        batch[n] = torch.cat([clip, clip.flip(-1)])                                   # [2, 5, C, 32, 32]
    assert module.clip_plan(5) == (0, 3, 3)

    def step() -> dict[str, torch.Tensor]:
        model.zero_grad(set_to_none=True)
        with torch.autocast("cpu", dtype=torch.bfloat16, enabled=half):
            pred = module.run_clip(batch, with_ref=True)
            loss = module.loss_fn(pred, batch["ref"][:, -pred.shape[1]:])["loss"]
        loss.backward()
        return {"pred": pred.detach(), "loss": loss.detach(),
                **{n: p.grad.clone() for n, p in model.named_parameters() if p.grad is not None}}

    calls = []
    original = TwoStage._run
    monkeypatch.setattr(TwoStage, "_run", lambda self, x, state_only: calls.append(state_only)
                        or original(self, x, state_only))
    fast = step()
    assert calls == [True, True, True, False, False]
    monkeypatch.setattr(TwoStage, "advance", lambda self, x: self(x))
    ref = step()
    assert fast.keys() == ref.keys() and len(ref) > 50
    for name in ref:
        assert torch.equal(fast[name], ref[name]), name
    monkeypatch.undo()                                           # the real advance, _run recorded again
    monkeypatch.setattr(TwoStage, "_run", lambda self, x, state_only: calls.append(state_only)
                        or original(self, x, state_only))
    calls.clear()
    with torch.no_grad():
        model.eval().reset()
        model.advance({k: v[:, 0] for k, v in batch.items()})
    assert calls == [False]                                      # outside training: the whole forward

"""The fast paths of mcd/models/fast_paths.py against their reference formulations (docs/inference.md "Fast
paths"): the kernel application in the kernels' layout, semantic alignment's attention in the autocast dtype,
channels-last G-buffers and block inputs; each on its own, and the bundled row F on rendered Cornell-box
frames (fp32 within 1e-4 relative of the reference; bf16 within 0.1 dB PSNR of fp32 against the rendered
reference)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mcd.core.metrics import psnr
from mcd.denoise.weights import load
from mcd.lit.precision import cpu_bf16_supported
from mcd.models import fast_paths
from mcd.models.inputs import gbuffers
from mcd.models.kernel_pool import KernelPool, apply_pixel_kernels, filter_below, interpolate_kernels
from mcd.models.latency import model_inputs
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


@pytest.fixture(scope="module")
def bundled_f():
    return load("F-cpu-small").model.eval().to(memory_format=CL)


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

"""The output's hue from the kernel pool's ``i_bar`` (``method.denoiser_hue=i_bar``, mcd/models/hue.py;
docs/method.md "Output"): the step keeps the luminance and takes the box-averaged hue, leaves black pixels and
HDR values sane, and in row F the output's luminance is ``F_d``'s while its hue is ``i_bar``'s, on a real
32x32 Cornell-box render; ``i_bar_detached`` passes no gradient to the pool through the hue; refused on a row
without the kernel pool."""

from __future__ import annotations

import pytest
import torch

from mcd.data import BUFFERS
from mcd.models import build
from mcd.models.hue import DARK, box_mean, hue_from, luminance
from tests.conftest import compose_cfg, store32_overrides


def _chroma(image: torch.Tensor) -> torch.Tensor:
    return image / luminance(image)


def test_luminance_is_kept_and_the_hue_is_the_guides_box_mean():
    g = torch.Generator().manual_seed(0)
    grey = torch.rand(2, 1, 9, 11, generator=g) * 1e5 + 0.01          # HDR up to 1e5
    guide = grey * torch.tensor([0.9, 0.6, 0.3]).view(1, 3, 1, 1)      # one warm hue everywhere
    output = torch.rand(2, 3, 9, 11, generator=g) * 50 + 0.01           # any hue
    mixed = hue_from(output, guide)
    assert torch.isfinite(mixed).all()
    torch.testing.assert_close(luminance(mixed), luminance(output), rtol=1e-5, atol=1e-5)
    torch.testing.assert_close(_chroma(mixed), _chroma(box_mean(guide)), rtol=1e-4, atol=1e-5)
    # a hue that changes from pixel to pixel is averaged over the 3x3 box, luminance-weighted
    guide[:, :, 4, 5] = torch.tensor([0.1, 0.2, 5.0]) * 1e3
    mixed = hue_from(output, guide)
    assert _chroma(mixed)[0, 2, 4, 5] < _chroma(guide)[0, 2, 4, 5]
    assert _chroma(mixed)[0, 2, 4, 6] > _chroma(guide)[0, 2, 4, 6]     # the neighbour took some blue
    torch.testing.assert_close(_chroma(mixed)[0, :, 4, 8], _chroma(guide)[0, :, 4, 8])  # outside the box: not


def test_black_and_dark_pixels_keep_their_own_colour_and_nothing_is_nan():
    output = torch.rand(1, 3, 8, 8) + 0.1
    guide = torch.zeros(1, 3, 8, 8)                                    # an all-black i_bar
    assert torch.equal(hue_from(output, guide), output)
    guide = torch.rand(1, 3, 8, 8) + 0.1
    output[..., 2, 3] = 0.0                                            # a black output pixel
    output[..., 5, 5] = DARK / 4                                       # and a dark one
    mixed = hue_from(output, guide)
    assert torch.equal(mixed[..., 2, 3], output[..., 2, 3])
    assert torch.equal(mixed[..., 5, 5], output[..., 5, 5])
    one_pixel = torch.rand(1, 3, 1, 1) + 0.1                           # a 1x1 frame: no box to average over
    torch.testing.assert_close(luminance(hue_from(one_pixel, one_pixel * 2)), luminance(one_pixel))


def _frame(store) -> dict[str, torch.Tensor]:
    return {b: torch.from_numpy(store.load("cbox", 0, b)).permute(2, 0, 1)[None] for b in BUFFERS}


def _model(cbox_store, *overrides: str):
    plain = ["method.mean_match=false", "method.output_bound=false", "method.pass_misses=false"]
    cfg = compose_cfg(*store32_overrides(cbox_store[1].data_dir), *plain, *overrides)
    torch.manual_seed(0)
    return build(cfg).eval()


def test_row_f_takes_f_ds_luminance_and_i_bars_hue_on_a_real_render(cbox_store):
    x = _frame(cbox_store[1])
    with torch.no_grad():
        free = _model(cbox_store)(x)
        hue = _model(cbox_store, "method.denoiser_hue=i_bar")(x)
    torch.testing.assert_close(hue["initial"], free["initial"])        # same weights, same i_bar
    lit = (luminance(free["output"]) > DARK) & (luminance(box_mean(free["initial"])) > DARK)
    assert lit.float().mean() > 0.5
    torch.testing.assert_close(luminance(hue["output"])[lit], luminance(free["output"])[lit],
                               rtol=1e-4, atol=1e-5)
    want = _chroma(box_mean(free["initial"]))
    got = _chroma(hue["output"])
    torch.testing.assert_close(got[lit.expand_as(got)], want[lit.expand_as(want)], rtol=1e-3, atol=1e-4)
    assert not torch.allclose(free["output"], hue["output"])


def test_training_reaches_f_d_through_the_luminance(cbox_store):
    model = _model(cbox_store, "method.denoiser_hue=i_bar").train()
    out = model(_frame(cbox_store[1]))
    out["output"].mean().backward()
    grads = [p.grad for p in model.denoiser.parameters() if p.grad is not None]
    assert grads and any(g.abs().sum() > 0 for g in grads)


def _pool_grad(model) -> float:
    return sum(float(p.grad.abs().sum()) for n, p in model.named_parameters()
               if p.grad is not None and not n.startswith("denoiser."))


def test_the_detached_hue_passes_no_gradient_to_the_pool(cbox_store):
    """A loss on the output's chromaticity alone (its luminance divided out) reaches the kernel pool and F_s
    under ``i_bar`` and not under ``i_bar_detached``; both give the same output."""
    x = _frame(cbox_store[1])
    outputs, grads = {}, {}
    for hue in ("i_bar", "i_bar_detached"):
        model = _model(cbox_store, f"method.denoiser_hue={hue}").train()
        out = model(x)["output"]
        lit = luminance(out).detach() > DARK
        (_chroma(out) * lit).sum().backward()
        outputs[hue], grads[hue] = out.detach(), _pool_grad(model)
    torch.testing.assert_close(outputs["i_bar"], outputs["i_bar_detached"])
    assert grads["i_bar"] > 0
    # detached, only float rounding is left: the chromaticity divides F_d's luminance out, and that
    # cancellation's residue flows back through F_d's input (measured: 24,000 against 0.02)
    assert grads["i_bar_detached"] < 1e-5 * grads["i_bar"]


def test_a_row_without_the_kernel_pool_is_refused(cbox_store):
    with pytest.raises(ValueError, match="method.denoiser_hue=i_bar takes the hue from the kernel pool"):
        _model(cbox_store, "+experiment=B", "method.denoiser_hue=i_bar")
    with pytest.raises(ValueError, match="method.denoiser_hue=i_bar_detached takes the hue"):
        _model(cbox_store, "+experiment=B", "method.denoiser_hue=i_bar_detached")
    with pytest.raises(ValueError, match="method.denoiser_hue='grey'"):
        _model(cbox_store, "method.denoiser_hue=grey")

"""The output's hue from the kernel pool's ``i_bar`` (``method.denoiser_hue=i_bar``, mcd/models/hue.py;
docs/method.md "Output"): the step keeps the luminance and takes the box-averaged hue, leaves black pixels and
HDR values sane, and in row F the output's luminance is ``F_d``'s while its hue is ``i_bar``'s, on a real
32x32 Cornell-box render; refused on a row without the kernel pool."""

from __future__ import annotations

import pytest
import torch

from mcd.data import BUFFERS
from mcd.models import build
from mcd.models.hue import DARK, box_mean, grey_correction, hue_from
from mcd.models.inputs import LUMA
from mcd.models.inputs import grey as luminance
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


def test_a_grey_correction_is_one_value_per_pixel_and_every_channel_gets_its_gradient():
    correction = torch.randn(2, 3, 5, 7, requires_grad=True)
    g = grey_correction(correction)
    assert torch.equal(g[:, 0], g[:, 1]) and torch.equal(g[:, 1], g[:, 2])
    torch.testing.assert_close(g[:, :1], luminance(correction))
    g.sum().backward()
    torch.testing.assert_close(correction.grad[0, :, 0, 0], 3 * torch.tensor(LUMA))


def test_row_f_with_a_grey_correction_takes_i_bars_hue(cbox_store):
    """``i_bar_grey`` on a real render: ``F_d``'s own three output channels differ (the grey step, not the
    network, makes its correction one value per pixel), the output takes ``i_bar``'s 3x3 hue, and training
    reaches ``F_d``."""
    x = _frame(cbox_store[1])
    model = _model(cbox_store, "method.denoiser_hue=i_bar_grey")
    seen = {}
    model.denoiser.register_forward_hook(lambda m, i, o: seen.update(correction=o.detach()))
    with torch.no_grad():
        out = model(x)
    c = seen["correction"]
    assert not torch.equal(c[:, 0], c[:, 1])
    lit = (luminance(out["output"]) > DARK) & (luminance(box_mean(out["initial"])) > DARK)
    got, want = _chroma(out["output"]), _chroma(box_mean(out["initial"]))
    torch.testing.assert_close(got[lit.expand_as(got)], want[lit.expand_as(want)], rtol=1e-3, atol=1e-4)
    model = _model(cbox_store, "method.denoiser_hue=i_bar_grey").train()
    model(x)["output"].mean().backward()
    assert any(p.grad is not None and p.grad.abs().sum() > 0 for p in model.denoiser.parameters())


def test_a_row_without_the_kernel_pool_is_refused(cbox_store):
    with pytest.raises(ValueError, match="method.denoiser_hue=i_bar takes the hue from the kernel pool"):
        _model(cbox_store, "+experiment=B", "method.denoiser_hue=i_bar")
    with pytest.raises(ValueError, match="method.denoiser_hue=i_bar_grey takes the hue"):
        _model(cbox_store, "+experiment=B", "method.denoiser_hue=i_bar_grey")
    with pytest.raises(ValueError, match="method.denoiser_output=direct has none"):
        _model(cbox_store, "method.denoiser_hue=i_bar_grey", "method.denoiser_output=direct")
    with pytest.raises(ValueError, match="method.denoiser_hue='grey'"):
        _model(cbox_store, "method.denoiser_hue=grey")

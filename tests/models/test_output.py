"""The output options of the two-stage model (docs/method.md "Output"): method.mean_match
(mcd/models/mean_match.py) and method.denoiser_output."""

import torch

from mcd.models.mean_match import GAIN_MAX, match_frame_mean


def test_output_takes_the_renders_frame_mean_per_channel():
    g = torch.Generator().manual_seed(0)
    render = torch.rand(2, 3, 17, 23, generator=g) * torch.tensor([1.0, 1e5, 0.3]).view(1, 3, 1, 1)
    out = torch.rand(2, 3, 17, 23, generator=g) * torch.tensor([0.7, 9e4, 0.4]).view(1, 3, 1, 1)
    matched = match_frame_mean(out, render)
    torch.testing.assert_close(matched.mean((-2, -1)), render.mean((-2, -1)), rtol=1e-5, atol=1e-6)
    # the gain scales, so the image's structure is kept
    torch.testing.assert_close(matched / matched.mean((-2, -1), keepdim=True),
                               out / out.mean((-2, -1), keepdim=True), rtol=1e-5, atol=1e-6)


def test_a_wrong_light_does_not_rescale_the_rest_of_the_frame():
    """Two bands: a visible light (most of the frame's linear energy) that the output gets 5x too dark is
    corrected on its own, and the rest (20% too dark) on its own; the frame mean is matched as a whole; HDR
    values up to 1e5 stay finite."""
    render = torch.full((1, 3, 16, 16), 0.5)
    render[..., :2, :2] = 1e5
    out = torch.full((1, 3, 16, 16), 0.4)
    out[..., :2, :2] = 2e4
    matched = match_frame_mean(out, render)
    torch.testing.assert_close(matched[..., 4:, 4:], torch.full((1, 3, 12, 12), 0.5))
    torch.testing.assert_close(matched[..., :2, :2], torch.full((1, 3, 2, 2), 1e5))
    torch.testing.assert_close(matched.mean((-2, -1)), render.mean((-2, -1)))


def test_an_output_too_bright_around_a_right_light_gets_no_halo():
    """The bands are told apart at the render's scale (the medians' ratio), so the output's own scale does not
    move a pixel between them: an output whose light is right but whose rest is 3x too bright, as a trained
    F's was, is corrected by the rest's gain up to the light's edge. Before, the pixels next to the light
    (3.0 in the output, in the blend between the bands) kept part of the light's gain of 1 and came out about
    twice too bright: a bright ring, which rMSE weighs (docs/method.md "Output")."""
    render = torch.full((1, 3, 24, 24), 0.3)
    render[..., 9:12, 9:12] = 1e5            # the light
    ring = torch.zeros(1, 1, 24, 24, dtype=torch.bool)
    ring[..., 8:13, 8:13] = True
    ring[..., 9:12, 9:12] = False
    render = torch.where(ring, torch.tensor(1.0), render)
    out = torch.where(render > 1e3, render, 3.0 * render)
    matched = match_frame_mean(out, render)
    torch.testing.assert_close(matched, render, rtol=1e-3, atol=0.0)
    for k in (0.5, 2.0):  # scaling the output leaves the result as it was, the light included
        torch.testing.assert_close(match_frame_mean(out * k, render), matched, rtol=1e-4, atol=0.0)


def test_black_frames_stay_black_and_the_gain_is_clamped():
    black = torch.zeros(1, 3, 8, 8)
    assert torch.equal(match_frame_mean(black, black), black)
    out = torch.full((1, 3, 8, 8), 1e-3)
    render = torch.ones(1, 3, 8, 8)
    torch.testing.assert_close(match_frame_mean(out, render), out * GAIN_MAX)


def test_gradients_are_finite_for_an_all_zero_output_channel():
    y = torch.zeros(1, 3, 8, 8, requires_grad=True)
    out = y * torch.tensor([1.0, 0.0, 1.0]).view(1, 3, 1, 1) + 0.5
    match_frame_mean(out, torch.rand(1, 3, 8, 8)).sum().backward()
    assert torch.isfinite(y.grad).all()


def test_two_stage_output_takes_the_frame_mean_of_what_f_d_denoised():
    """Row F: the adaptive image ``i``; row A: the uniform render ``c_4``; off by default."""
    from mcd.models import build
    from tests.models.helpers import frame, row_cfg

    x = frame(h=24, w=40, scale=3.0)
    for row, render in (("F", None), ("A", "c4")):
        cfg = row_cfg(row)
        cfg.method.mean_match, cfg.method.denoiser_output = False, "direct"
        torch.manual_seed(0)
        plain = build(cfg).eval()
        last = [m for m in plain.denoiser.modules() if isinstance(m, torch.nn.Conv2d)][-1]
        with torch.no_grad():  # an untrained F_d's output is black (clamped at 0): give it a colour
            last.bias += torch.tensor([0.6, 1.0, 0.8])  # expm1: 0.8-1.7, within a gain of 8 of the render
        cfg.method.mean_match = True
        matched = build(cfg).eval()
        matched.load_state_dict(plain.state_dict())
        with torch.no_grad():
            out = matched(x)
            base = plain(x)["output"]
        want = out["adaptive"] if render is None else x[render]
        torch.testing.assert_close(out["output"].mean((-2, -1)), want.mean((-2, -1)), rtol=1e-4, atol=1e-5)
        assert not torch.allclose(base.mean((-2, -1)), want.mean((-2, -1)), rtol=1e-2)


def test_mean_match_test_applies_in_eval_mode_only():
    """``method.mean_match=test``: the model in training mode returns F_d's output as it is (the loss sees the
    network's own scale), in eval mode (validation, test) the matched one, the same as ``true`` gives; an
    unknown value is named before anything runs."""
    import pytest

    from mcd.models import build
    from tests.models.helpers import frame, row_cfg

    x = frame(h=24, w=40, scale=3.0)
    cfg = row_cfg("F")
    outputs = {}
    for mode in (False, True, "test"):
        cfg.method.mean_match = mode
        torch.manual_seed(0)
        model = build(cfg)
        last = [m for m in model.denoiser.modules() if isinstance(m, torch.nn.Conv2d)][-1]
        with torch.no_grad():
            last.bias += torch.tensor([0.6, 1.0, 0.8])  # an output far from the render's mean
            trained = model.train()(x)["output"]
            model.reset()   # a new sequence: F_d reads a wider frame in eval mode (method.denoiser_margin)
            outputs[mode] = (trained, model.eval()(x)["output"])
    plain, matched, test = outputs[False], outputs[True], outputs["test"]
    torch.testing.assert_close(test[0], plain[0])    # training: no gain
    torch.testing.assert_close(test[1], matched[1])  # validation and test: the gain
    assert not torch.allclose(plain[1], matched[1], rtol=1e-2)
    cfg.method.mean_match = "train"
    with pytest.raises(ValueError, match="method.mean_match='train'"):
        build(cfg)


def test_residual_denoiser_output_starts_from_its_colour_input():
    """With F_d's last convolution zeroed, ``residual`` returns F_d's colour input (row F: i_bar; row A: c_4)
    and ``direct`` returns black; an unknown value is named."""
    import pytest

    from mcd.models import build
    from tests.models.helpers import frame, row_cfg

    x = frame(h=24, w=40, scale=3.0)
    for row in ("F", "A"):
        cfg = row_cfg(row)
        cfg.method.mean_match = False
        outputs = {}
        for mode in ("direct", "residual"):
            cfg.method.denoiser_output = mode
            model = build(cfg).eval()
            last = [m for m in model.denoiser.modules() if isinstance(m, torch.nn.Conv2d)][-1]
            with torch.no_grad():
                last.weight.zero_()
                last.bias.zero_()
                outputs[mode] = model(x)
        want = outputs["residual"]["initial"] if row == "F" else x["c4"]
        torch.testing.assert_close(outputs["residual"]["output"], want, rtol=1e-4, atol=1e-4)
        assert float(outputs["direct"]["output"].abs().max()) == 0.0
    cfg.method.denoiser_output = "skip"
    with pytest.raises(ValueError, match="method.denoiser_output='skip'"):
        build(cfg)

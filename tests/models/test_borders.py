"""The sampling network at the frame's border (``method.sampler_padding``; docs/method.md "Adaptive sampling",
step 6): with replicate padding a flat input gives a flat map up to the border, so no sample goes to the
border for being the border; with zero padding (``F_paper``'s, the paper's plain convolutions) the border
looks like an edge. A config without the key (one written before the option) is refused, naming it."""

import pytest
import torch

from mcd.models.cpu_fast.ghost_conv import grouped_conv
from mcd.models.registry import build
from mcd.models.sampler import SamplingNetwork
from mcd.sampling import normalise_map, shares
from tests.models.helpers import frame, row_cfg


def _sampler(padding: str, ghost: bool) -> SamplingNetwork:
    torch.manual_seed(0)
    return SamplingNetwork([8, 16, 32], 2, kernel_pool=True, ghost=ghost, padding=padding,
                           kp_cfg={"q": 16, "size": 5, "lift_hidden": 128, "alpha_hidden": 64, "window": 5,
                                   "descriptor": 16, "head_widths": [8, 8]},
                           kp_options={"head_output": "rms_centred", "highlight": 1.0, "skip_misses": False})


def _flat_input(h: int = 37, w: int = 50) -> torch.Tensor:
    x = torch.full((1, 12, h, w), 0.3)
    x[:, 3:6] = torch.tensor([0.0, 0.0, 1.0]).view(1, 3, 1, 1)   # one flat wall: normal along z
    return x


@pytest.mark.parametrize("ghost", [True, False])
@pytest.mark.parametrize("mode", ["train", "inference"])
def test_replicate_padding_keeps_a_flat_frames_map_flat_to_the_border(ghost, mode):
    """Odd sizes (padded to the U-Net's stride inside), both block kinds, the training and the CPU inference
    paths: every pixel of a flat frame gets the same logit, hence the budget's samples, border included."""
    net = _sampler("replicate", ghost)
    x = _flat_input()
    if mode == "train":
        logits = net.train()(x)["logits"].detach()
    else:
        with torch.inference_mode():
            logits = net.eval()(x)["logits"]
    assert float(logits.max() - logits.min()) < 1e-5
    m = normalise_map(shares(logits), budget=4)
    assert float(m.min()) == float(m.max()) == 3.0


def test_zero_padding_makes_the_border_of_a_flat_frame_look_like_an_edge():
    """The mechanism the option removes: the same untrained network with zero padding gives the border pixels
    of a flat frame other logits than the interior's."""
    logits = _sampler("zeros", ghost=True)(_flat_input())["logits"].detach()[0, 0]
    centre = logits[logits.shape[0] // 2, logits.shape[1] // 2]
    assert float((logits[0] - centre).abs().max()) > 1e-3


@pytest.mark.parametrize("padding_mode", ["zeros", "replicate"])
def test_cpu_training_path_of_grouped_convs_keeps_the_padding_mode(padding_mode):
    torch.manual_seed(0)
    conv = torch.nn.Conv2d(12, 8, 7, padding=3, groups=4, padding_mode=padding_mode)
    x = torch.randn(2, 12, 9, 10, requires_grad=True)
    torch.testing.assert_close(grouped_conv(conv, x), conv(x))


def _padding_modes(model: torch.nn.Module) -> set[str]:
    """The padding modes of the sampler's convolutions that pad."""
    return {m.padding_mode for m in model.sampler.modules()
            if isinstance(m, torch.nn.Conv2d) and m.padding != (0, 0)}


def test_row_f_pads_its_sampler_by_replication_and_a_config_without_the_key_is_refused():
    cfg = row_cfg("F")
    assert cfg.method.sampler_padding == "replicate"
    assert _padding_modes(build(cfg)) == {"replicate"}
    cfg.method.sampler_padding = "zeros"   # as conf/experiment/F_paper.yaml sets it
    model = build(cfg)
    assert _padding_modes(model) == {"zeros"}
    with torch.no_grad():
        assert torch.isfinite(model.eval()(frame(24, 24))["output"]).all()
    del cfg.method["sampler_padding"]   # a config written before the option: no default stands in for it
    with pytest.raises(ValueError, match=r"method two_stage needs sampler_padding: set them in method\.\* "
                                         r"\(conf/method/two_stage\.yaml\)"):
        build(cfg)


def test_the_denoiser_reads_the_frame_reflected_by_its_margin_outside_training_only():
    """``method.denoiser_margin`` (docs/method.md "Frame edges"): in evaluation ``F_d`` runs on its input
    reflected by 16 pixels and the output is cropped back; in training it runs on the crop as it is."""
    import torch.nn.functional as F

    torch.manual_seed(0)
    model = build(row_cfg("F"))
    assert model.denoiser_margin == 16
    cin = next(m for m in model.denoiser.unet.encoder.modules() if isinstance(m, torch.nn.Conv2d)).in_channels
    z = torch.rand(1, cin, 20, 28)

    def fresh(run, x):   # each call a first frame (semantic alignment keeps the last frame's features)
        model.reset()
        return run(x)

    with torch.no_grad():
        plain = fresh(model.denoiser.eval(), z)
        reflected = fresh(model.denoiser, F.pad(z, (16, 16, 16, 16), mode="reflect"))[..., 16:-16, 16:-16]
        torch.testing.assert_close(fresh(model.eval().denoise, z), reflected)
        torch.testing.assert_close(fresh(model.train().denoise, z), fresh(model.denoiser.train(), z))
    edge = (reflected - plain)[..., 0, :].abs().max()
    assert float(edge) > 1e-4   # the margin changes what the edge pixels see


@pytest.mark.parametrize("size", [(9, 13), (24, 24)])
def test_a_frame_smaller_than_the_margin_is_reflected_as_far_as_it_goes(size):
    model = build(row_cfg("F")).eval()
    with torch.no_grad():
        out = model(frame(*size))["output"]
    assert out.shape[-2:] == size and torch.isfinite(out).all()


def test_configs_from_before_the_margin_keep_none_and_a_negative_one_is_refused():
    cfg = row_cfg("F")
    del cfg.method["denoiser_margin"]   # a config written before the option (the bundled F's)
    assert build(cfg).denoiser_margin == 0
    cfg.method.denoiser_margin = -1
    with pytest.raises(ValueError, match="method.denoiser_margin=-1"):
        build(cfg)

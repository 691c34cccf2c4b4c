"""The paper's loss (docs/method.md "Losses") and the loss registry."""

import logging
from pathlib import Path

import pytest
import torch
from omegaconf import OmegaConf

from mcd import losses
from mcd.losses.paper import compress
from mcd.losses.vgg import vgg16_features

CONF = Path(__file__).resolve().parents[2] / "conf"


def cfg(**loss):
    base = OmegaConf.load(CONF / "loss" / "paper.yaml")
    return OmegaConf.create({"loss": OmegaConf.merge(base, loss), "paths": {"vgg16_weights": None}})


def test_loss_configs_are_the_constructors_arguments():
    """Every conf/loss/*.yaml builds (its keys are its loss's constructor arguments, ``name`` aside)."""
    for path in sorted((CONF / "loss").glob("*.yaml")):
        c = OmegaConf.create({"loss": OmegaConf.load(path), "paths": {"vgg16_weights": None}})
        assert c.loss.name == path.stem
        assert isinstance(losses.build_loss(c), torch.nn.Module)


def clip(seed=0, shape=(2, 5, 3, 8, 8)):
    g = torch.Generator().manual_seed(seed)
    return torch.rand(shape, generator=g) * 4


def test_config_weights_are_the_papers():
    c = cfg()
    assert (c.loss.w_s, c.loss.w_t, c.loss.w_p, c.loss.space) == (0.8, 0.2, 0.1, "log1p")


def test_l_s_reads_only_the_last_frame_and_l_t_only_the_last_two():
    loss = losses.build_loss(cfg())
    pred, ref = clip(0), clip(1)
    base = loss(pred, ref)
    changed = pred.clone()
    changed[:, :3] += 1.0  # frames that neither term reads
    again = loss(changed, ref)
    assert torch.equal(base["loss"], again["loss"])
    changed[:, 3] += 1.0  # the second-last frame: L_t changes, L_s does not
    third = loss(changed, ref)
    assert torch.equal(third["l_s"], base["l_s"]) and not torch.equal(third["l_t"], base["l_t"])


def test_known_values_in_linear_and_log1p_space():
    ref = torch.zeros(1, 2, 3, 4, 4)
    pred = ref.clone()
    pred[:, -1] = 1.0  # last frame off by 1, previous frame exact
    lin = losses.build_loss(cfg(space="linear"))(pred, ref)
    assert lin["l_s"].item() == pytest.approx(1.0) and lin["l_t"].item() == pytest.approx(1.0)
    assert lin["loss"].item() == pytest.approx(0.8 + 0.2)
    log = losses.build_loss(cfg())(pred, ref)
    assert log["l_s"].item() == pytest.approx(torch.log1p(torch.tensor(1.0)).item())


def test_hdr_and_negative_outputs_stay_finite_with_gradients():
    loss = losses.build_loss(cfg())
    pred = torch.full((1, 2, 3, 4, 4), -5.0, requires_grad=True)
    ref = torch.full((1, 2, 3, 4, 4), 1e5)
    out = loss(pred, ref)
    out["loss"].backward()
    assert torch.isfinite(out["loss"]) and torch.isfinite(pred.grad).all() and pred.grad.abs().sum() > 0


def test_perceptual_off_without_weights_logged_and_recorded(caplog):
    with caplog.at_level(logging.WARNING):
        loss = losses.build_loss(cfg())
    assert loss.perceptual_status.on is False and "null" in loss.perceptual_status.reason
    assert "L_p is OFF" in caplog.text
    assert "l_p" not in loss(clip(0), clip(1))


def test_perceptual_on_with_a_weights_file(tmp_path):
    feats = vgg16_features()
    path = tmp_path / "vgg16.pth"
    torch.save({f"features.{k}": v for k, v in feats.state_dict().items()}, path)
    c = cfg()
    c.paths.vgg16_weights = str(path)  # loss.vgg16_weights is ${paths.vgg16_weights}
    loss = losses.build_loss(c)
    assert loss.perceptual_status.on
    pred = clip(0, (1, 2, 3, 32, 32)).requires_grad_(True)
    out = loss(pred, clip(1, (1, 2, 3, 32, 32)))
    assert out["l_p"] > 0
    expected = 0.8 * out["l_s"] + 0.2 * out["l_t"] + 0.1 * out["l_p"]
    assert out["loss"].item() == pytest.approx(expected.item())
    out["loss"].backward()
    assert pred.grad[:, -1].abs().sum() > 0


def test_log1p_compression_is_odd_and_has_slope_one_at_zero():
    x = torch.tensor([-3.0, -0.0, 0.0, 2.0, 1e4], requires_grad=True)
    y = compress(x, "log1p")
    assert torch.allclose(y, torch.sign(x) * torch.log1p(x.abs()))
    y.sum().backward()
    assert torch.allclose(x.grad, 1 / (1 + x.detach().abs()))  # 1 at exactly 0: a zero output still learns


def test_all_zero_output_gets_a_gradient():
    pred = torch.zeros(1, 2, 3, 4, 4, requires_grad=True)
    losses.build_loss(cfg())(pred, torch.ones(1, 2, 3, 4, 4))["loss"].backward()
    assert (pred.grad[:, -1] < 0).all()


def test_clip_of_one_frame_with_temporal_weight_is_an_error():
    with pytest.raises(ValueError, match="clip_len"):
        losses.build_loss(cfg())(clip(0, (1, 1, 3, 4, 4)), clip(1, (1, 1, 3, 4, 4)))


def test_unknown_loss_a_wrong_key_and_a_wrong_space_are_clear_errors():
    with pytest.raises(ValueError, match="unknown loss.name='nope'.*paper"):
        losses.build_loss(cfg(name="nope"))
    with pytest.raises(ValueError, match="conf/loss/paper.yaml"):
        losses.build_loss(cfg(w_q=1.0))
    with pytest.raises(ValueError, match="loss.space"):
        losses.build_loss(cfg(space="srgb"))


def test_register_loss_makes_a_loss_buildable_by_name():
    @losses.register_loss("test_only_l1")
    def factory(reduction: str):
        return torch.nn.L1Loss(reduction=reduction)

    try:
        built = losses.build_loss(OmegaConf.create({"loss": {"name": "test_only_l1", "reduction": "sum"}}))
        assert isinstance(built, torch.nn.L1Loss) and built.reduction == "sum"
        with pytest.raises(ValueError, match="registered twice"):
            losses.register_loss("test_only_l1")(lambda: None)
    finally:
        losses.LOSSES.unregister("test_only_l1")


def test_an_old_config_naming_its_module_is_refused_naming_the_key_and_the_loss_file():
    """Run configs written before mcd/losses/ carry ``loss.module`` (a Python module path): no longer dropped,
    refused before any work with the settings and the loss's YAML; without it the same loss builds."""
    old = {"loss": {"name": "mse", "module": "mcd.lit.baseline_losses", "space": "log1p"}}
    with pytest.raises(ValueError, match=r"loss 'mse': its settings \['module', 'space'\] do not fit .*"
                                         r"unexpected keyword argument 'module'.*see conf/loss/mse\.yaml"):
        losses.build_loss(OmegaConf.create(old))
    del old["loss"]["module"]
    assert type(losses.build_loss(OmegaConf.create(old))).__name__ == "MSELoss"

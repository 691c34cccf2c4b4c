"""The config groups mirror the code (docs/architecture.md "Layout"): every ``+experiment=<X>`` composes to
its method's ``conf/method/`` file (with the row's switches for A-M), its loss's ``conf/loss/`` file, and a
trainer without the keys ``train.*`` owns; every group file builds through its registry."""

from __future__ import annotations

from pathlib import Path

import pytest
from omegaconf import OmegaConf, open_dict

from mcd.config.compose import experiment_names
from mcd.config.methods import COMPONENTS, TABLE1_VARIANTS
from mcd.lit import budget
from mcd.losses import LOSSES, build_loss
from mcd.models import METHODS
from mcd.models.switches import SWITCHES
from tests.conftest import compose_cfg

CONF = Path(__file__).resolve().parents[1] / "conf"
EXPERIMENTS = experiment_names()
#: The baselines' own losses (docs/baselines.md); every other experiment trains with the paper's.
#: ``method.name`` of rows A-M (a variant of a row, such as F_paper, is one too).
COMPONENT_METHOD = "two_stage"
OWN_LOSS = {"rae": "rae", "fastdvdnet": "mse", "dasr": "dasr", "ntasad": "ntasad", "ntasad_no_warp": "ntasad",
            "ntasad_no_previous": "ntasad"}


def group_file(group: str, name: str) -> dict:
    """``conf/<group>/<name>.yaml`` as composed on its own (its defaults list applied)."""
    cfg = compose_cfg(f"{group}={name}")
    return OmegaConf.to_container(cfg[group], resolve=False)  # type: ignore[return-value]


@pytest.mark.slow
@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_experiment_composes_to_its_method_and_loss_files(experiment: str) -> None:
    cfg = compose_cfg(f"+experiment={experiment}")
    method = OmegaConf.to_container(cfg.method, resolve=False)
    assert cfg.experiment == experiment
    if experiment in COMPONENTS:  # rows A-M: the two-stage file with the row's switches
        expected = {**group_file("method", "two_stage"), **COMPONENTS[experiment]["switches"]}
    else:  # its method's file, with the settings the experiment's own file changes (F_paper's)
        of = TABLE1_VARIANTS.get(experiment, experiment)
        expected = group_file("method", COMPONENT_METHOD if of in COMPONENTS else of)
        assert expected["name"] == (COMPONENT_METHOD if of in COMPONENTS else of)
        own = OmegaConf.load(CONF / "experiment" / f"{experiment}.yaml").get("method", {})
        expected = OmegaConf.to_container(OmegaConf.merge(expected, own))
    assert method == expected
    assert cfg.loss.name == OWN_LOSS.get(experiment, "paper")
    assert OmegaConf.to_container(cfg.loss) == group_file("loss", cfg.loss.name)
    assert not set(cfg.trainer) & set(budget.FROM_TRAIN)
    kwargs = budget.trainer_kwargs(cfg)
    assert kwargs["limit_train_batches"] == cfg.train.limit_train_batches
    assert kwargs["gradient_clip_val"] == cfg.train.grad_clip


def test_the_default_method_builds_row_f_as_documented_and_unet_is_row_a() -> None:
    """What the default config builds (docs/method.md "Output", docs/kernel_pool.md): row F with a residual
    ``F_d`` on ``log1p`` colour, the stack of 5 levels, ``F_d`` reading ``i_bar`` (not ``i``), the soft-RMS
    kernel-map head and the output steps; the U-Net experiment builds row A's network and gives its output."""
    import torch

    from mcd.models import build
    from mcd.models.complexity import dummy_batch

    f = build(compose_cfg())
    assert f.sw == dict.fromkeys(SWITCHES, True)
    assert (f.residual, f.colour, f.levels, f.reads_adaptive) == (True, "log1p", 5, False)
    assert f.sampler.head.output == "rms_soft" and len(f._forward_hooks) == 1
    torch.manual_seed(0)
    unet = build(compose_cfg("+experiment=unet")).eval()
    torch.manual_seed(0)
    row_a = build(compose_cfg("+experiment=A")).eval()
    x = dummy_batch(unet, 24, 24, "cpu")
    with torch.no_grad():
        torch.testing.assert_close(unet(x)["output"], row_a(x)["output"])


@pytest.mark.slow
def test_every_group_file_names_a_registered_entry() -> None:
    methods = sorted(p.stem for p in (CONF / "method").glob("*.yaml"))
    assert methods == METHODS.names()
    assert all(group_file("method", n)["name"] == n for n in methods)
    losses = sorted(p.stem for p in (CONF / "loss").glob("*.yaml"))
    assert losses == LOSSES.names()
    for name in losses:
        assert build_loss(compose_cfg(f"loss={name}", "paths.vgg16_weights=null")) is not None


def test_one_registry_type_for_methods_and_losses() -> None:
    """Both registries are :class:`mcd.core.registry.Registry`: the same plug-in rule and the same errors."""
    from torch import nn

    from mcd.core.registry import Registry, UnknownName
    from mcd.models import build, register

    assert isinstance(METHODS, Registry) and isinstance(LOSSES, Registry)
    cfg = compose_cfg("+experiment=A")
    with open_dict(cfg):
        cfg.method.name = "test_only_identity"
        cfg.method.denoiser_margin = 0  # an identity has no denoiser to reflect the input for
    with pytest.raises(UnknownName, match="unknown method.name='test_only_identity'.*two_stage"):
        build(cfg)

    @register("test_only_identity")
    def identity(**kwargs):  # the factory gets its own settings as plain kwargs, nothing else
        assert kwargs["budget"] == cfg.budget and kwargs["UN"] is True and "name" not in kwargs
        assert "two_stage" not in kwargs and "denoiser" not in kwargs  # its capacity entry: none
        return nn.Identity()

    try:
        assert isinstance(build(cfg), nn.Identity)
        with pytest.raises(ValueError, match="method 'test_only_identity' is registered twice"):
            register("test_only_identity")(lambda **kwargs: None)
    finally:
        METHODS.unregister("test_only_identity")


def test_factories_take_plain_kwargs_from_build() -> None:
    """``METHODS.get(name)(**kwargs)`` (BasicSR's style): ``build`` hands each factory its method settings,
    its capacity entry and the budget as keywords; a key the factory does not take, or one it needs that the
    config lacks, is refused naming it."""
    import inspect

    import torch

    from mcd.models import METHODS, build
    from mcd.models.registry import factory_kwargs

    cfg = compose_cfg("+experiment=rae", "capacity=cpu")
    kwargs = factory_kwargs(cfg)
    assert kwargs == {"budget": 4.0, "encoder": list(cfg.capacity.rae.encoder),
                      "bottleneck": cfg.capacity.rae.bottleneck, "last": list(cfg.capacity.rae.last)}
    direct = METHODS.get("rae")(**kwargs)
    built = build(cfg)
    assert [p.shape for p in direct.parameters()] == [p.shape for p in built.parameters()]
    knobs = list(inspect.signature(METHODS.get("rae")).parameters)
    assert knobs == ["budget", "encoder", "bottleneck", "last"]
    unet = factory_kwargs(compose_cfg("+experiment=unet", "capacity=paper"))
    assert unet["denoiser"]["widths"] == [32, 64, 64, 64, 64]  # unet reads capacity.two_stage
    with open_dict(cfg):
        cfg.method.depth = 3
    with pytest.raises(ValueError, match=r"method.depth \(or capacity.rae.depth\): not a setting of method"):
        build(cfg)
    cfg = compose_cfg("+experiment=rae", "capacity=cpu")
    with open_dict(cfg):
        del cfg.capacity.rae.bottleneck
    with pytest.raises(ValueError, match=r"method rae needs bottleneck"):
        build(cfg)
    cfg = compose_cfg("+experiment=F")
    with open_dict(cfg):
        cfg.method.ghost = {"kernel": 3}
    with pytest.raises(ValueError, match=r"method.ghost and capacity.two_stage.ghost both set"):
        build(cfg)
    cfg = compose_cfg("+experiment=unet", "+method.colors=none")  # unet hands two_stage's check its keys
    with torch.device("meta"), pytest.raises(ValueError, match=r"method.colors \(or capacity.two_stage"):
        build(cfg)

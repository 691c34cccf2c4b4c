"""The two-stage model of every component row A-M (docs/method.md "The five switches"; docs/architecture.md
"Models")."""

import pytest
import torch

from mcd.models import build
from mcd.models.switches import check_switches
from tests.models.helpers import ROWS, frame, row_cfg, switch_cfg

STACK = {"c1", "c2", "c4", "c8", "c16", "c32"}
GBUF = {"depth", "normal", "albedo"}


@pytest.mark.parametrize("row", sorted(ROWS))
def test_row_builds_and_trains_one_step_on_32x32(row):
    torch.manual_seed(0)
    model = build(row_cfg(row))
    bits = ROWS[row]
    model.reset()
    out = model(frame())
    assert out["output"].shape == (1, 3, 32, 32)
    assert bool((out["output"] >= 0).all()) and bool(torch.isfinite(out["output"]).all())
    assert ("sampling_map" in out) == (bits[1] == "1")
    assert ("kernel_map" in out and "initial" in out) == (bits[2] == "1")
    (out["output"].mean() + sum(v.float().mean() for k, v in out.items() if k == "initial")).backward()
    grads = {n: p.grad for n, p in model.named_parameters()}
    missing = [n for n, g in grads.items() if g is None]
    assert not missing, f"parameters without gradient: {missing[:5]}"
    if bits[1] == "1":
        head = model.sampler.unet.head.weight.grad
        assert float(head.abs().sum()) > 0, "the DASR gradient reaches the sampling network"


def test_required_buffers_follow_the_switches():
    assert build(row_cfg("A")).required_buffers() == {"c4"} | GBUF
    assert build(row_cfg("A", budget=8)).required_buffers() == {"c8"} | GBUF
    assert build(row_cfg("F")).required_buffers() == {"c1_in"} | STACK | GBUF


@pytest.mark.parametrize("bits,name", [("101000", "KP"), ("100010", "FG"), ("100011", "FG")])
def test_impossible_switches_fail_at_build_time_and_say_why(bits, name):
    with pytest.raises(ValueError, match=f"method.{name}=true needs method.AS=true"):
        build(switch_cfg(bits))


def test_switch_errors():
    with pytest.raises(ValueError, match="UN=false"):
        check_switches({"UN": False, "AS": False, "KP": False, "PP": False, "FG": False, "SA": False},
                       complete=True)
    with pytest.raises(ValueError, match="booleans"):
        check_switches({"UN": True, "AS": "yes", "KP": False, "PP": False, "FG": False, "SA": False},
                       complete=True)
    with pytest.raises(ValueError, match="lacks switches"):
        check_switches({"UN": True}, complete=True)


def test_bad_budgets_are_named():
    with pytest.raises(ValueError, match="uniform render"):
        build(row_cfg("A", budget=3))
    with pytest.raises(ValueError, match="1 < s"):
        build(row_cfg("F", budget=1))


@pytest.mark.parametrize("size", [(1, 1), (7, 5), (33, 17), (15, 40)])
@pytest.mark.parametrize("row", ["A", "F"])
def test_odd_and_tiny_sizes_are_padded_and_cropped(row, size):
    model = build(row_cfg(row))
    model.reset()
    out = model(frame(*size))
    for key, value in out.items():
        assert value.shape[-2:] == size, key
    if "sampling_map" in out:
        assert int(out["sampling_map"].sum()) == size[0] * size[1] * 3, "budget over the real pixels only"


def test_missing_buffer_is_named():
    x = frame()
    del x["c16"]
    with pytest.raises(KeyError, match="c16"):
        build(row_cfg("B"))(x)


def test_temporal_state_across_a_clip_keeps_the_graph():
    torch.manual_seed(0)
    model = build(row_cfg("M"))
    model.reset()
    frames = [frame(seed=s) for s in range(3)]
    outs = [model(f)["output"] for f in frames]
    outs[-1].square().mean().backward()  # not .mean(): method.mean_match pins the output's mean
    grad_last = {n: p.grad.clone() for n, p in model.named_parameters() if p.grad is not None}
    model.zero_grad()
    model.reset()
    model(frames[2])["output"].square().mean().backward()    # the same frame without history
    differs = any(not torch.allclose(grad_last[n], p.grad) for n, p in model.named_parameters()
                  if p.grad is not None and n in grad_last)
    assert differs, "the last frame's loss depends on the earlier frames through the SA state"
    model.reset()
    a = model(frames[0])["output"]
    model.reset()
    torch.testing.assert_close(model(frames[0])["output"], a)


@pytest.mark.parametrize(("row", "stateful"), [("F", True), ("M", True), ("A", False)])
def test_window_and_reset_interface(row, stateful):
    """One frame per call (window (0, 0)); with SA the output depends on the frames since the last reset(),
    and reset() forgets them (the next output equals a fresh sequence's); without SA it never does."""
    torch.manual_seed(0)
    model = build(row_cfg(row)).eval()
    assert model.window == (0, 0)
    f0, f1 = frame(seed=1), frame(seed=2)
    with torch.no_grad():
        model.reset()
        fresh = model(f1)["output"]
        model.reset()
        model(f0)
        after_f0 = model(f1)["output"]
        model.reset()
        model(f0)
        model.reset()
        after_reset = model(f1)["output"]
    # exact comparisons: at initialisation the SA history moves the output by only ~1e-5
    assert torch.equal(after_reset, fresh)
    assert (not torch.equal(after_f0, fresh)) == stateful

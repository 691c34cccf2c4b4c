"""``method.pass_misses`` (mcd/models/misses.py; docs/method.md "Output"): pixels whose G-buffer normal is
exactly 0 (no first hit) keep the value of the render the method denoised; every other pixel is the output as
without the switch."""

from __future__ import annotations

import pytest
import torch

from mcd.models import build
from mcd.models.misses import miss_mask
from tests.baselines.helpers import frame
from tests.conftest import compose_cfg


def _with_misses(x: dict[str, torch.Tensor]) -> tuple[dict[str, torch.Tensor], torch.Tensor]:
    """``x`` with no geometry in a 3-pixel frame border and a 4x5 block (normal, depth, albedo 0): the
    mask, ``[1, 1, H, W]``."""
    like = x["normal"][:, 0] if x["normal"].dim() == 5 else x["normal"]
    mask = torch.zeros(1, 1, *like.shape[-2:], dtype=torch.bool)
    mask[..., :3, :] = mask[..., -3:, :] = mask[..., :, :3] = mask[..., :, -3:] = True
    mask[..., 10:14, 20:25] = True
    x = dict(x)
    for key in ("normal", "depth", "albedo"):
        m = mask if x[key].dim() == 4 else mask[:, None]
        x[key] = x[key].masked_fill(m, 0.0)
    return x, mask


@pytest.mark.parametrize("experiment", ["F", "A", "rae", "fastdvdnet", "dasr", "ntasad", "oidn"])
def test_pixels_without_geometry_keep_the_render_the_method_denoised(experiment):
    if experiment == "oidn":
        pytest.importorskip("pyoidn")
    cfg = compose_cfg(f"+experiment={experiment}")
    assert cfg.method.pass_misses is True                            # the default of every method but noisy
    torch.manual_seed(0)
    passing = build(cfg).eval()
    with torch.no_grad():  # away from the initialisation (FastDVDnet's starts as its input)
        for p in passing.parameters():
            p.add_(0.02 * torch.randn_like(p))
    cfg.method.pass_misses = False
    plain = build(cfg).eval()
    plain.load_state_dict(passing.state_dict())
    past, future = passing.window
    x = frame(h=32, w=48, seed=5, t=past + future + 1 if (past, future) != (0, 0) else None)
    x, mask = _with_misses(x)
    with torch.no_grad():
        out = passing(x)
        base = plain(x)["output"]
    c4 = x["c4"][:, past] if x["c4"].dim() == 5 else x["c4"]
    render = out.get("adaptive", c4)
    m = mask.expand_as(base)
    assert torch.equal(out["output"][m], render.to(out["output"].dtype)[m])
    assert torch.equal(out["output"][~m], base[~m])
    assert not torch.allclose(base[m], render[m], atol=1e-3)          # the switch changed something


def test_the_mask_is_exactly_zero_normals_only():
    normal = torch.tensor([[0.0, 0.0, 0.0], [0.0, 0.0, 1e-7], [0.0, -0.0, 0.0], [0.6, 0.0, 0.8]])
    normal = normal.T.reshape(1, 3, 1, 4)
    assert miss_mask(normal).flatten().tolist() == [True, False, True, False]


def test_the_noisy_input_has_no_pass_through():
    assert "pass_misses" not in compose_cfg("+experiment=noisy").method

"""Every learned baseline ends in the frame-mean match of rows A-M (``method.mean_match``; docs/baselines.md
"Output"): matched to its own adaptive image (DASR, NTASAD) or to the current frame of the uniform render
(RAE, FastDVDnet), with the same parameters as without it."""

from __future__ import annotations

import pytest
import torch

from mcd.models import build
from mcd.models.mean_match import match_frame_mean
from tests.conftest import compose_cfg

from .helpers import frame


@pytest.mark.parametrize("method", ["rae", "fastdvdnet", "dasr", "ntasad"])
def test_a_baseline_output_takes_the_frame_mean_of_what_it_denoised(method):
    cfg = compose_cfg(f"+experiment={method}")
    assert cfg.method.mean_match == "test"                      # the default of every learned baseline
    torch.manual_seed(0)
    matched = build(cfg).eval()
    cfg.method.mean_match = False
    plain = build(cfg).eval()
    assert matched.state_dict().keys() == plain.state_dict().keys()   # a hook: checkpoints load either way
    plain.load_state_dict(matched.state_dict())
    past, future = matched.window
    x = frame(h=32, w=48, seed=3, t=past + future + 1 if (past, future) != (0, 0) else None)
    with torch.no_grad():
        out = matched(x)
        base = plain(x)
    current = x["c4"][:, past] if x["c4"].dim() == 5 else x["c4"]
    render = out.get("adaptive", current)
    # a render the hook must not have used: another frame of the window, or a far darker one (an untrained
    # output can be more than GAIN_MAX below the render; this one's gain clamps at 1 / GAIN_MAX instead)
    other = (x["c4"][:, 0] if x["c4"].dim() == 5 else render) * 1e-4
    torch.testing.assert_close(out["output"], match_frame_mean(base["output"], render), rtol=1e-5, atol=1e-6)
    assert not torch.allclose(out["output"], match_frame_mean(base["output"], other), rtol=1e-3)
    assert torch.isfinite(out["output"]).all()

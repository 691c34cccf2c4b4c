"""NTASAD's feedback warp (docs/baselines.md "NTASAD"): zero motion is the identity, a shift moves content."""

from __future__ import annotations

import pytest
import torch

from mcd.models.warp import warp


def test_zero_motion_is_identity() -> None:
    prev = torch.rand(2, 3, 17, 23, generator=torch.Generator().manual_seed(0)) * 100
    out = warp(prev, torch.zeros(2, 2, 17, 23))
    # float32 round trip of the sampling grid: ~1e-6 px, i.e. ~1e-4 on values up to 100
    torch.testing.assert_close(out, prev, rtol=1e-5, atol=1e-3)


@pytest.mark.parametrize(("dx", "dy"), [(3, 0), (0, -2), (4, 5)])
def test_known_shift_moves_content_by_that_shift(dx: int, dy: int) -> None:
    """Frame t is frame t-1 moved by (dx, dy): pixel p of t was at p - (dx, dy), so motion = -(dx, dy)."""
    torch.manual_seed(0)
    prev = torch.rand(1, 3, 32, 40)
    cur = torch.roll(prev, shifts=(dy, dx), dims=(2, 3))
    motion = torch.empty(1, 2, 32, 40)
    motion[:, 0], motion[:, 1] = -dx, -dy
    out = warp(prev, motion)
    ys = slice(max(dy, 0), 32 + min(dy, 0))
    xs = slice(max(dx, 0), 40 + min(dx, 0))  # away from the wrapped-around border
    torch.testing.assert_close(out[..., ys, xs], cur[..., ys, xs], rtol=1e-5, atol=1e-5)


def test_half_pixel_shift_interpolates() -> None:
    prev = torch.arange(8.0).view(1, 1, 1, 8).expand(1, 1, 4, 8).contiguous()
    motion = torch.zeros(1, 2, 4, 8)
    motion[:, 0] = 0.5
    out = warp(prev, motion)
    torch.testing.assert_close(out[..., :7], prev[..., :7] + 0.5)


def test_mismatched_motion_is_an_error() -> None:
    with pytest.raises(ValueError, match="motion"):
        warp(torch.zeros(1, 3, 8, 8), torch.zeros(1, 2, 8, 9))

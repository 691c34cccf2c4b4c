"""`python -m mcd.render`: which buffers it renders, and the --force shorthand."""

from __future__ import annotations

import sys

import pytest

from mcd.data import BUFFERS
from mcd.render import _argv_flags, requested_buffers
from tests.conftest import compose_cfg


def test_requested_buffers():
    f = requested_buffers(compose_cfg())  # row F: what the two-stage model reads, plus ref
    assert {"ref", "c1_in", "c1", "c32"} <= f and f <= set(BUFFERS)
    assert requested_buffers(compose_cfg("render.buffers=all")) == set(BUFFERS)
    assert requested_buffers(compose_cfg("render.buffers=[c4]")) == {"c4", "ref"}
    with pytest.raises(ValueError, match="render.buffers"):
        requested_buffers(compose_cfg("render.buffers=everything"))


def test_force_flag(monkeypatch):
    monkeypatch.setattr(sys, "argv", ["mcd.render", "data=tiny", "--force"])
    _argv_flags()
    assert sys.argv == ["mcd.render", "data=tiny", "render.force=true"]

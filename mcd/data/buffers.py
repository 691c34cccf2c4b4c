"""The store's buffers in one table: name, channels, kind, samples per pixel (docs/architecture.md,
"The store"; docs/data.md, "Buffers, seeds, store").

Every list of buffer names or channel counts in ``mcd`` (the store, its builder, the datamodule, the models'
``required_buffers``, the uniform baselines, the bench, the complexity count, the synthetic frames of
:mod:`mcd.data.synthetic`) is derived from :data:`TABLE`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

from omegaconf import DictConfig

from mcd.core.config_rules import UNIFORM_BUDGETS

__all__ = ["UNIFORM_BUDGETS"]  # the budgets with a uniform render, from the config's rule of ``budget``

#: ``input``: the 1 spp render the sampling network sees; ``uniform``: the stack of independent renders at
#: 2^k spp (the simulated adaptive render's stack, and the uniform renders at budget s); ``reference``;
#: ``gbuffer``: first-hit features of one ``aov`` render; ``motion``: computed from depth and the cameras.
Kind = Literal["input", "uniform", "reference", "gbuffer", "motion"]
COLOUR_KINDS = ("input", "uniform", "reference")


@dataclass(frozen=True)
class Buffer:
    """One stored buffer (an EXR of ``channels`` float32 channels per frame)."""

    name: str
    channels: int
    kind: Kind
    #: samples per pixel; None where the data profile sets it (``ref``: ``data.ref_spp``, G-buffers:
    #: ``data.gbuffer_spp``); 0 for ``motion`` (computed, not rendered)
    spp: int | None
    #: negative values are meaningful (kept when sanitising; docs/data.md)
    signed: bool = False

    @property
    def colour(self) -> bool:
        """Linear HDR radiance: multiplied by the scene's exposure at load, compressed inside models."""
        return self.kind in COLOUR_KINDS


TABLE: tuple[Buffer, ...] = (
    Buffer("c1_in", 3, "input", 1),
    *(Buffer(f"c{s}", 3, "uniform", s) for s in UNIFORM_BUDGETS),
    Buffer("ref", 3, "reference", None),
    Buffer("depth", 1, "gbuffer", None),
    Buffer("normal", 3, "gbuffer", None, signed=True),
    Buffer("albedo", 3, "gbuffer", None),
    Buffer("motion", 2, "motion", 0, signed=True),
)
BY_NAME: dict[str, Buffer] = {b.name: b for b in TABLE}
#: every buffer name, in table order (the order of rendering and of the datamodule's keys)
BUFFERS: tuple[str, ...] = tuple(BY_NAME)
COLOUR_BUFFERS: tuple[str, ...] = tuple(b.name for b in TABLE if b.colour)
GBUFFERS: tuple[str, ...] = tuple(b.name for b in TABLE if b.kind == "gbuffer")
#: the uniform renders by name, with their spp (``c1`` .. ``c32``)
SPP_BUFFERS: dict[str, int] = {b.name: int(b.spp or 0) for b in TABLE if b.kind == "uniform"}
CHANNELS: dict[str, int] = {b.name: b.channels for b in TABLE}
#: buffers whose negative values are meaningful (normals in [-1, 1], motion in pixels)
NEGATIVE_OK: frozenset[str] = frozenset(b.name for b in TABLE if b.signed)


def buffer_spp(buffer: str, data_cfg: DictConfig) -> int:
    """Samples per pixel of a stored buffer: the table's, else the data profile's (``ref``: ``data.ref_spp``,
    G-buffers: ``data.gbuffer_spp``)."""
    b = BY_NAME[buffer]
    if b.spp is not None:
        return b.spp
    return int(data_cfg.ref_spp) if b.kind == "reference" else int(data_cfg.gbuffer_spp)


def uniform_buffer(budget: float) -> str:
    """The uniform render at budget ``s`` (average spp), ``c{s}`` ("Uniform methods at budget s read
    ``c{s}``", docs/architecture.md)."""
    return f"c{int(budget)}"


def run_buffers(required: Iterable[str], budget: float) -> set[str]:
    """What a run renders and loads: the buffers the model reads, ``ref`` (loss and metrics) and the uniform
    render at the budget (the noisy input the metrics compare with)."""
    return set(required) | {"ref", uniform_buffer(budget)}


def validate_buffers(buffers: Iterable[str]) -> set[str]:
    """``buffers`` as a set; ValueError naming the unknown ones and the table."""
    bad = sorted(set(buffers) - set(BUFFERS))
    if bad:
        raise ValueError(f"unknown buffer(s) {bad}; the store holds {list(BUFFERS)} (docs/architecture.md)")
    return set(buffers)

"""Augmentations of training clips after OIDN's training toolkit (docs/training.md, "Augmentations").

The paper trains without augmentation (docs/method.md); the bundled checkpoints (``data=bundle``) turn these
on so that a model trained on a few scenes holds up on a user's. Each one is switched by a key of
``data.augment`` and draws one choice per clip, the same for every frame and buffer of the clip:

- ``channels``: one random permutation of the RGB channels, applied together to every radiance buffer
  (``c1_in``, the uniform renders ``c1 .. c32``, the target ``ref``) and to ``albedo``; not to ``normal``,
  ``depth`` or ``motion``, whose channels are geometry, not colour.
- ``exposure_stops = e``: every radiance buffer (the per-spp renders the sampling map and the adaptive render
  read included, and the target) multiplied by one factor ``2^u``, ``u`` uniform in ``[-e, e]``; ``albedo`` is
  reflectance and stays. The factor is lowered where it would take the clip's largest value above
  :data:`EXPOSURE_LIMIT`, so an HDR clip stays finite.
- ``zero_pad = p``, ``zero_pad_max = m``: with probability ``p``, the last ``0 .. m-1`` rows and columns of
  the crop (each drawn separately) become zero in every buffer, as beyond a frame's edge; drawn before the
  flips, so the band lands on any side.
- ``flips``: a vertical and a horizontal flip, each with probability 1/2; ``transpose``: the two image axes
  swapped with probability 1/2. ``motion`` (backward motion in pixels, ``(x, y)``; docs/architecture.md)
  follows: a horizontal flip negates its ``x``, a vertical flip its ``y``, a transpose swaps them, so it
  still warps frame ``t-1`` onto frame ``t``. Normals are world-space (Mitsuba's ``sh_normal``) and do not
  change under a flip of the image.
- ``reverse``: the clip's frames played backwards with probability 1/2, so the loss, which reads the clip's
  last frames (Sec. 4.2), also reads the first frames of a training range that a forward clip only warms up
  on (docs/training.md "Augmentations"). BasicSR's video training draws the same ``flip_sequence``. Backward
  motion cannot be turned into the reversed clip's (that is the forward motion, which the store does not
  hold), so a clip with a ``motion`` buffer is refused (:meth:`Augment.check_buffers`).

OIDN's ``training/dataset.py`` draws the flips, the transpose and the colour permutation the same way, and
pads 10% of its tiles with up to 15 zero rows and columns; it also permutes normal channels, which this module
does not (our normals are world-space and the network reads their direction). The exposure scale is this
module's own: OIDN normalises exposure at preprocessing instead.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import torch
from omegaconf import DictConfig

from mcd.core.config_rules import checked
from mcd.data.buffers import COLOUR_BUFFERS

#: The largest absolute value the exposure scale may produce: far above any radiance, far below float32's
#: largest finite value (3.4e38), so the models' log1p and squares of it stay finite.
EXPOSURE_LIMIT = 1e30
#: The keys of ``data.augment`` and their values when the block or a key is absent (all off).
DEFAULTS: dict[str, Any] = {"flips": False, "transpose": False, "channels": False, "zero_pad": 0.0,
                            "zero_pad_max": 16, "exposure_stops": 0.0, "reverse": False}
#: Channel-permuted with the radiance buffers.
PERMUTED = (*COLOUR_BUFFERS, "albedo")


@dataclass(frozen=True)
class Draw:
    """One clip's random choices: ``perm`` (channel order or None), ``scale`` (radiance factor), ``pad``
    (zero rows, zero columns at the crop's bottom and right, before flips), ``flip_y``, ``flip_x``,
    ``transpose``, ``reverse`` (frame order)."""

    perm: tuple[int, int, int] | None = None
    scale: float = 1.0
    pad: tuple[int, int] = (0, 0)
    flip_y: bool = False
    flip_x: bool = False
    transpose: bool = False
    reverse: bool = False


@dataclass(frozen=True)
class Augment:
    """The switches of ``data.augment`` (module docstring); :meth:`__call__` augments one clip."""

    flips: bool = False
    transpose: bool = False
    channels: bool = False
    zero_pad: float = 0.0
    zero_pad_max: int = 16
    exposure_stops: float = 0.0
    reverse: bool = False

    @classmethod
    def from_cfg(cls, data_cfg: DictConfig, crop: int | None = None,
                 buffers: Iterable[str] | None = None) -> Augment | None:
        """The augmentations ``data_cfg.augment`` switches on, or None if none is (or the block is absent).

        ValueError naming the key for an unknown key, a probability outside [0, 1], negative stops, a
        ``zero_pad_max`` below 1 or, where zero padding is on (``zero_pad > 0``), above the training crop
        (``crop``: ``data.train_crop``; with padding off a smaller crop was refused blaming this key), or,
        where the run's ``buffers`` are given, an augmentation they cannot take (:meth:`check_buffers`).
        """
        block = data_cfg.get("augment")
        if block is None:
            return None
        raw = dict(block)
        unknown = sorted(set(raw) - set(DEFAULTS))
        if unknown:
            raise ValueError(f"data.augment: unknown key(s) {unknown}; the keys are {sorted(DEFAULTS)} "
                             "(docs/training.md, 'Augmentations')")
        v = {**DEFAULTS, **raw}
        for key in ("flips", "transpose", "channels", "reverse"):
            if not isinstance(v[key], bool):
                raise ValueError(f"data.augment.{key}={v[key]!r}: give true or false")
        p = float(checked("data.augment.zero_pad", v["zero_pad"]))  # the ranges: mcd/core/config_rules.py
        stops = float(checked("data.augment.exposure_stops", v["exposure_stops"]))
        m = v["zero_pad_max"]
        limit = crop if crop is not None else int(data_cfg.train_crop)
        if not isinstance(m, int) or m < 1 or (p > 0 and m > limit):  # bounded by the crop where it pads
            raise ValueError(f"data.augment.zero_pad_max={m!r}: give an integer in 1 .. data.train_crop "
                             f"({limit}), where data.augment.zero_pad={p:g} pads the crops")
        aug = cls(v["flips"], v["transpose"], v["channels"], p, m, stops, v["reverse"])
        if buffers is not None:
            aug.check_buffers(buffers)
        return aug if aug.active else None

    @property
    def active(self) -> bool:
        """Whether any augmentation is on."""
        return (self.flips or self.transpose or self.channels or self.zero_pad > 0 or self.exposure_stops > 0
                or self.reverse)

    def check_buffers(self, buffers: Iterable[str]) -> None:
        """ValueError naming ``data.augment.reverse`` if it is on and the run loads ``motion``: backward
        motion does not reverse (module docstring)."""
        if self.reverse and "motion" in buffers:
            raise ValueError("data.augment.reverse=true: this method reads the motion buffer, and backward "
                             "motion cannot be reversed with the clip; set data.augment.reverse=false "
                             "(docs/training.md, 'Augmentations')")

    def describe(self) -> str:
        """One line for the log: what is on."""
        parts = [name for name in ("flips", "transpose", "channels", "reverse") if getattr(self, name)]
        if self.zero_pad > 0:
            parts.append(f"zero_pad {self.zero_pad:g} (up to {self.zero_pad_max - 1} px)")
        if self.exposure_stops > 0:
            parts.append(f"exposure +-{self.exposure_stops:g} stops")
        return ", ".join(parts) or "none"

    def sample(self, generator: torch.Generator | None = None) -> Draw:
        """One clip's choices, from ``generator`` (default: torch's global generator, which the data
        loader seeds per worker)."""

        def coin(p: float) -> bool:
            return p > 0 and float(torch.rand((), generator=generator)) < p

        def draw_int(high: int) -> int:
            return int(torch.randint(0, high, (), generator=generator))

        perm = tuple(int(i) for i in torch.randperm(3, generator=generator)) if self.channels else None
        scale = 1.0
        if self.exposure_stops > 0:
            scale = 2.0 ** ((2 * float(torch.rand((), generator=generator)) - 1) * self.exposure_stops)
        pad = (draw_int(self.zero_pad_max), draw_int(self.zero_pad_max)) if coin(self.zero_pad) else (0, 0)
        return Draw(perm=perm, scale=scale, pad=pad,  # type: ignore[arg-type]
                    flip_y=self.flips and coin(0.5), flip_x=self.flips and coin(0.5),
                    transpose=self.transpose and coin(0.5), reverse=self.reverse and coin(0.5))

    def __call__(self, clip: dict[str, Any], generator: torch.Generator | None = None) -> dict[str, Any]:
        """``clip`` (``{buffer: [T, C, h, w], ...}``) augmented by one :meth:`sample`."""
        return apply(clip, self.sample(generator))


def apply(clip: dict[str, Any], draw: Draw) -> dict[str, Any]:
    """A copy of ``clip`` with ``draw`` applied to its image buffers (its ``[T, C, h, w]`` tensors; other
    entries pass through, but for ``frame``, which ``reverse`` reverses with them). The input tensors are not
    modified (they may be the datamodule's cache)."""
    images = {k: v for k, v in clip.items() if isinstance(v, torch.Tensor) and v.ndim == 4}
    out = dict(clip)
    scale = draw.scale
    if scale != 1.0:
        colour = [images[b] for b in COLOUR_BUFFERS if b in images and images[b].numel()]
        peak = max((float(t.abs().max()) for t in colour), default=0.0)
        if peak * scale > EXPOSURE_LIMIT:
            scale = EXPOSURE_LIMIT / peak
    for name, t in images.items():
        if draw.perm is not None and name in PERMUTED:
            t = t[:, list(draw.perm)]
        if scale != 1.0 and name in COLOUR_BUFFERS:
            t = t * torch.tensor(scale, dtype=t.dtype)
        py, px = draw.pad
        if py or px:
            t = t.clone()
            if py:
                t[..., t.shape[-2] - py :, :] = 0
            if px:
                t[..., t.shape[-1] - px :] = 0
        if draw.flip_y:
            t = t.flip(-2)
        if draw.flip_x:
            t = t.flip(-1)
        if draw.transpose:
            t = t.transpose(-2, -1)
        if name == "motion":
            t = _motion(t, draw)
        if draw.reverse:
            t = t.flip(0)
        out[name] = t.contiguous()
    if draw.reverse and isinstance(clip.get("frame"), torch.Tensor):
        out["frame"] = clip["frame"].flip(0)
    return out


def _motion(t: torch.Tensor, draw: Draw) -> torch.Tensor:
    """Backward motion ``[T, 2 (x, y), h, w]`` (already moved with the image) with its components changed
    as the flips and the transpose change the image axes."""
    sign = torch.tensor([-1.0 if draw.flip_x else 1.0, -1.0 if draw.flip_y else 1.0], dtype=t.dtype)
    t = t * sign.view(1, 2, 1, 1)
    return t[:, [1, 0]] if draw.transpose else t

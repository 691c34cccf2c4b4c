"""The reference of ``mcd-denoise --scene``'s scores (docs/denoise.md, "Scores of the real loop"), rendered to
a target quality as the store renders its test frames' references (docs/data.md, "Reference quality";
:mod:`mcd.data.reference_quality`).

Every reference is two independent halves of ``spp / 2`` samples; their difference estimates the reference's
own noise (:func:`~mcd.data.reference_quality.estimate_psnr`), which every score line prints. On the first
frame whose pilot is not black (frame 0, unless it renders black) a pilot at ``--reference-spp`` sets the
exposure (the pilot's mean becomes the exposure target, as the store's ``exposure: auto``; unless
``--exposure`` is given) and its estimate sets the spp of every later frame's reference
(:func:`~mcd.data.reference_quality.spp_for_target`: ``--reference-db``, capped at ``--reference-max-spp``).
A black pilot tells neither (a black frame 0 gave the scores an exposure of 1, and the lit frames after it
were scored far too dark): the frames until a lit one keep their pilot, black, as their reference.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from mcd.data.exposure import auto_exposure
from mcd.data.reference_quality import estimate_psnr, spp_for_target
from mcd.data.renderer import derive_seed

#: The default target of the reference's own PSNR (dB), as the store's ``data.ref_quality.target_db``.
TARGET_DB = 40.0
#: The default cap of the reference's spp, as the ``small`` profile's ``data.ref_quality.max_spp``.
MAX_SPP = 4096


def check_settings(pilot_spp: int, target_db: float | None, max_spp: int) -> None:
    """Refuse settings the reference cannot use, naming the flag (before anything is rendered)."""
    if pilot_spp < 0 or pilot_spp == 1 or pilot_spp % 2:
        raise ValueError(f"--reference-spp={pilot_spp}: give 0 (no reference, no scores) or an even "
                         "number of at least 2 (the reference is two halves whose difference estimates its "
                         "noise)")
    if pilot_spp and max_spp < pilot_spp:
        raise ValueError(f"--reference-max-spp={max_spp} is below --reference-spp={pilot_spp}: raise the cap")
    if target_db is not None and not 0 < target_db < 100:
        raise ValueError(f"--reference-db={target_db}: give a target between 0 and 100 dB, or 0 to keep "
                         "--reference-spp")


@dataclass
class Reference:
    """A frame's reference (linear radiance, ``H x W x 3``), its spp and its estimated own PSNR (dB) after
    ``exposure``."""

    image: np.ndarray
    spp: int
    psnr_estimate: float


def render_halves(renderer: Any, spp: int, seed: int, frame: int) -> tuple[np.ndarray, np.ndarray]:
    """Two independent renders of ``spp / 2`` samples each of the renderer's current camera."""
    return tuple(renderer.color(spp // 2, derive_seed(seed, "ref", half, spp, frame)) for half in "ab")


class ReferencePlan:
    """The first lit frame's pilot decides the exposure and the spp (:attr:`settled` from then on);
    :meth:`render` renders any later frame's reference."""

    def __init__(self, pilot_spp: int, target_db: float | None, max_spp: int, seed: int) -> None:
        check_settings(pilot_spp, target_db, max_spp)
        self.pilot_spp, self.target_db, self.max_spp, self.seed = pilot_spp, target_db, max_spp, seed
        self.spp = pilot_spp
        self.pilot_db: float | None = None
        #: Whether a pilot that is not black has set the exposure and the spp.
        self.settled = False

    def first(self, renderer: Any, exposure: float | None, exposure_target: float,
              frame: int = 0) -> tuple[Reference, float | None]:
        """Frame ``frame`` (the renderer at its camera), called until :attr:`settled`: the pilot, the exposure
        (``exposure``, or from the pilot's mean) and the chosen spp; returns the frame's reference and the
        exposure (None while the pilots are black and no ``exposure`` is given)."""
        a, b = render_halves(renderer, self.pilot_spp, self.seed, frame)
        measured = auto_exposure((a + b) / 2, exposure_target)
        if measured is None:  # black: the pilot is the frame's reference, and the next frame's pilot decides
            self.pilot_db = estimate_psnr(a, b, exposure or 1.0)
            return Reference((a + b) / 2, self.pilot_spp, self.pilot_db), exposure
        self.settled = True
        if exposure is None:
            exposure = measured
        self.pilot_db = estimate_psnr(a, b, exposure)
        if self.target_db is not None:
            self.spp = spp_for_target(self.pilot_spp, self.pilot_db, self.target_db, self.max_spp)
        if self.spp == self.pilot_spp:
            return Reference((a + b) / 2, self.spp, self.pilot_db), exposure
        return self.render(renderer, frame, exposure), exposure

    def render(self, renderer: Any, frame: int, exposure: float) -> Reference:
        """Frame ``frame``'s reference at the chosen spp (the renderer at its camera)."""
        a, b = render_halves(renderer, self.spp, self.seed, frame)
        return Reference((a + b) / 2, self.spp, estimate_psnr(a, b, exposure))

    def summary(self) -> dict[str, Any]:
        """What the report records: pilot spp and estimate, target, cap, the spp every frame got."""
        return {"pilot_spp": self.pilot_spp, "pilot_db": self.pilot_db, "target_db": self.target_db,
                "max_spp": self.max_spp, "spp": self.spp}

"""Mitsuba variant selection (docs/data.md, "Mitsuba variant").

`select_variant` must run before anything else imports drjit or mitsuba in the process: it sets
``DRJIT_LIBLLVM_PATH`` to Debian's ``libLLVM-19.so`` when that file exists and the variable is unset (an older
LLVM aborts the LLVM backend, docs/data.md), then tries ``cuda_ad_rgb``, ``llvm_ad_rgb`` and ``scalar_rgb`` in
that order and keeps the first that renders a 4x4 test image. The CUDA and LLVM probes run in a child process
because a bad LLVM library aborts the interpreter instead of raising, and a GPU without OptiX fails only when
rendering.
"""

from __future__ import annotations

import logging
import os
import subprocess
import sys
from pathlib import Path

log = logging.getLogger(__name__)

LLVM19 = Path("/usr/lib/x86_64-linux-gnu/libLLVM-19.so")
AUTO_ORDER = ("cuda_ad_rgb", "llvm_ad_rgb", "scalar_rgb")

_PROBE = """
import mitsuba as mi
mi.set_variant("{variant}")
scene = mi.load_dict({{"type": "scene", "s": {{"type": "sphere"}}, "e": {{"type": "constant"}},
    "i": {{"type": "path"}},
    "sensor": {{"type": "perspective", "film": {{"type": "hdrfilm", "width": 4, "height": 4}}}}}})
img = mi.render(scene, spp=1)
assert img.numpy().shape == (4, 4, 3)
"""


def _configure_llvm_path() -> None:
    if "DRJIT_LIBLLVM_PATH" not in os.environ and LLVM19.exists():
        os.environ["DRJIT_LIBLLVM_PATH"] = str(LLVM19)


def _probe(variant: str) -> bool:
    """True when `variant` renders a tiny scene (in a child process, so that an abort cannot kill us)."""
    try:
        res = subprocess.run(
            [sys.executable, "-c", _PROBE.format(variant=variant)],
            capture_output=True,
            timeout=120,
            env=os.environ.copy(),
        )
    except subprocess.TimeoutExpired:
        return False
    return res.returncode == 0


def select_variant(requested: str = "auto") -> str:
    """Set and return the Mitsuba variant: `requested`, or with ``auto`` the fastest one that works here.

    Raises ``RuntimeError`` naming the variant and the ``render.variant`` key when an explicit variant fails.
    Calling it again returns the variant already set in this process (Mitsuba cannot change the backend of
    objects already loaded, so one variant per process).
    """
    _configure_llvm_path()
    import mitsuba as mi

    current = mi.variant()
    if current is not None and (requested in ("auto", current)):
        return current
    if requested != "auto":
        if requested not in mi.variants():
            raise RuntimeError(
                f"render.variant={requested!r} is not in this Mitsuba build's variants {mi.variants()}; "
                "set render.variant=auto or one of those"
            )
        mi.set_variant(requested)
        log.info("Mitsuba %s, variant %s (from render.variant)", mi.__version__, requested)
        return requested
    import drjit as dr

    for variant in AUTO_ORDER:
        if variant not in mi.variants():
            continue
        if variant.startswith("cuda") and not dr.has_backend(dr.JitBackend.CUDA):
            continue
        if variant.startswith("llvm") and not dr.has_backend(dr.JitBackend.LLVM):
            continue
        if variant != "scalar_rgb" and not _probe(variant):  # CUDA without OptiX, LLVM too old: fails here
            log.info("Mitsuba variant %s is present but failed a test render; trying the next", variant)
            continue
        mi.set_variant(variant)
        log.info(
            "Mitsuba %s, variant %s (auto: first working of %s; DRJIT_LIBLLVM_PATH=%s)",
            mi.__version__,
            variant,
            ", ".join(AUTO_ORDER),
            os.environ.get("DRJIT_LIBLLVM_PATH", "unset"),
        )
        return variant
    raise RuntimeError("no Mitsuba variant works here (not even scalar_rgb)")

"""How much work an ``mcd-denoise`` command asks for, estimated from its arguments before anything runs
(docs/denoise.md, "Limits"; docs/reliability.md, "Denoising your frames").

Scene mode counts the samples it will trace: per frame ``N * s`` colour samples (the budget), ``N *
gbuffer_spp`` for the G-buffers, ``N * reference_spp`` for a reference, the simulated render's stack
``N * (2^(levels+1) - 1)`` when an adaptive method is compared with it, and NTASAD's extra ``c_s`` on frame 0.
Frames mode counts the pixels it will denoise (pixels x frames). Above :data:`MAX_SAMPLES` or
:data:`MAX_PIXELS` the command is refused, naming the estimate and ``--allow-large``, which lifts the limit.
"""

from __future__ import annotations

#: Samples traced by one scene command: 2^32, about an hour at a million samples per second.
MAX_SAMPLES = 2**32
#: Pixels denoised by one frames command: 2^30, about 500 frames of 1920x1080.
MAX_PIXELS = 2**30
#: Parameters of a model built from a checkpoint's configuration: 2^28 (1 GiB in float32).
MAX_PARAMS = 2**28


class TooLargeError(ValueError):
    """The work the arguments ask for is above a documented limit; the message names ``--allow-large``."""


def scene_samples(width: int, height: int, frames: int, budget: int, gbuffer_spp: int, reference_spp: int,
                  adaptive: bool, levels: int, extra_first: bool) -> int:
    """Samples a scene command traces (module docstring); ``extra_first``: a uniform ``c_s`` on frame 0."""
    n = width * height
    per_frame = n * (budget + gbuffer_spp + reference_spp)
    if reference_spp and adaptive:
        per_frame += n * (2 ** (levels + 1) - 1)
    return frames * per_frame + (n * budget if extra_first else 0)


def check(amount: int, limit: int, what: str, allow_large: bool) -> None:
    """TooLargeError if ``amount`` (of ``what``) exceeds ``limit`` and ``allow_large`` is not set."""
    if amount > limit and not allow_large:
        raise TooLargeError(
            f"{what}: {amount:.3g}, above the limit of {limit:.3g} (mcd.denoise.work, docs/denoise.md "
            "'Limits'); lower the size, frames or samples, or pass --allow-large to run it anyway")

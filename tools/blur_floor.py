"""``python tools/blur_floor.py``: how much blur a scene's noisy input allows before FLIP says the blur is
worse (notes/dark_regions.md, "How much blur the input's FLIP allows").

FLIP (``mcd.core.metrics.flip``) weighs edges and discounts fine-grained noise, so on a small, lightly noisy
frame the noisy input can score a FLIP that only a sharp denoiser beats. For each test scene of a data
profile this tool scores, on the scene's test frames (the store's, as ``mcd.run`` tests them), the noisy
uniform render at the budget and the reference itself blurred by a Gaussian of standard deviation ``sigma``
pixels (per channel, edges extended), each against the reference, and prints a Markdown table: the input's
FLIP and PSNR, the blurred references' FLIP per ``sigma``, and the ``sigma`` at which the blurred reference's
FLIP reaches the input's (linear between the measured ones; ``> max`` when none does). A denoiser whose
output is softer than that ``sigma``, however clean, scores a worse FLIP than its input. OIDN's and the
trained methods' scores are in the runs' own ``frames.csv``.

What the store lacks of the test frames is rendered first. ``--write FILE`` replaces the text between
``<!-- blur-floor -->`` and ``<!-- /blur-floor -->`` in ``FILE`` with the table (``--section NAME``: between
``<!-- NAME -->`` lines), so that a documented table is the command's output.
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

import numpy as np
from omegaconf import DictConfig

from mcd.core.metrics import flip, psnr
from tools._doc_section import check, write_section

#: Default standard deviations of the Gaussian blur, in pixels.
SIGMAS = (0.5, 0.7, 1.0, 1.5, 2.0)
SECTION = "blur-floor"  # the marker lines of --write: <!-- blur-floor --> and <!-- /blur-floor -->


def blurred(image: np.ndarray, sigma: float) -> np.ndarray:
    """``image`` (``H x W x C``, linear) blurred per channel by a Gaussian of ``sigma`` pixels; the frame's
    edge pixels are extended beyond it (``nearest``), so that a border is not darkened."""
    from skimage.filters import gaussian

    return gaussian(image.astype(np.float64), sigma=sigma, mode="nearest", channel_axis=-1,
                    preserve_range=True).astype(np.float32)


def crossing(sigmas: list[float], scores: list[float], level: float) -> float | None:
    """The smallest ``sigma`` at which ``scores`` (FLIP of the reference blurred by each of ``sigmas``,
    ascending) reaches ``level``: linear between the two measured ones around it; 0 when the first is already
    at or above it; None when none reaches it."""
    if scores[0] >= level:
        return 0.0
    for k in range(1, len(sigmas)):
        if scores[k] >= level:
            s0, s1, f0, f1 = sigmas[k - 1], sigmas[k], scores[k - 1], scores[k]
            return s0 + (s1 - s0) * (level - f0) / (f1 - f0)
    return None


def scene_floor(frames: list[tuple[np.ndarray, np.ndarray]], sigmas: list[float]) -> dict[str, object]:
    """Means over ``frames`` (``(noisy, reference)`` pairs) of the input's FLIP and PSNR and of each blurred
    reference's FLIP, and the crossing ``sigma`` of those means."""
    input_flip = float(np.mean([flip(n, r) for n, r in frames]))
    input_psnr = float(np.mean([psnr(n, r) for n, r in frames]))
    by_sigma = [float(np.mean([flip(blurred(r, s), r) for _, r in frames])) for s in sigmas]
    return {"input_flip": input_flip, "input_psnr": input_psnr, "blurred_flip": by_sigma,
            "sigma_at_input": crossing(sigmas, by_sigma, input_flip)}


def table(cfg: DictConfig, sigmas: list[float]) -> str:
    """The Markdown table of the module docstring for ``cfg``'s test scenes, rendering what the store lacks
    first."""
    from mcd.data import StoreBuilder
    from mcd.data.buffers import uniform_buffer
    from mcd.data.shards import Selection
    from mcd.data.splits import test_frame_count

    noisy = uniform_buffer(float(cfg.budget))
    store = StoreBuilder.from_cfg(cfg)
    n_test = test_frame_count(store.n_frames, float(cfg.data.test_fraction))
    scenes = list(cfg.data.test_scenes)
    store.ensure({noisy, "ref"}, scenes=scenes, selection=Selection(frames=(0, n_test)), progress=False)
    head = ("| scene | frames | input PSNR (dB) | input FLIP | "
            + " | ".join(f"FLIP, reference blurred by {s:g} px" for s in sigmas)
            + " | blur at the input's FLIP (px) |\n|" + "---|" * (5 + len(sigmas)) + "\n")
    rows = []
    for scene in scenes:
        pairs = [(store.load(scene, f, noisy), store.load(scene, f, "ref")) for f in range(n_test)]
        s = scene_floor(pairs, sigmas)
        at = s["sigma_at_input"]
        cross = f"> {max(sigmas):g}" if at is None else f"{at:.2f}"
        cells = " | ".join(f"{v:.4f}" for v in s["blurred_flip"])  # type: ignore[union-attr]
        rows.append(f"| {scene} | {n_test} | {s['input_psnr']:.2f} | {s['input_flip']:.4f} | {cells} | "
                    f"{cross} |")
    return head + "\n".join(rows) + "\n"


def provenance(argv: list[str], cfg: DictConfig) -> str:
    """What the table came from: command, commit, machine, data."""
    import torch

    from mcd.core.machine import device_name
    from mcd.core.provenance import short_commit

    d = cfg.data
    command = " ".join(["python tools/blur_floor.py", *map(shlex.quote, argv)])
    q = d.ref_quality
    return (f"`{command}` at commit {short_commit()}, {device_name(torch.device('cpu'))}. Data profile "
            f"`{d.name}` ({d.width}x{d.height}), noisy input at {cfg.budget} spp, each scene's test frames, "
            f"references to {q.target_db} dB at most {q.max_spp} spp.\n\n")


def main(argv: list[str] | None = None) -> None:
    argv = list(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(prog="python tools/blur_floor.py", description=__doc__.split("\n\n")[0])
    p.add_argument("--data", default="tiny", help="the data profile whose test scenes are scored")
    p.add_argument("--sigma", type=float, action="append", dest="sigmas",
                   help=f"a blur in pixels; repeat for more (default: {', '.join(map(str, SIGMAS))})")
    p.add_argument("--write", type=Path, help="also write the table into this file between the markers")
    p.add_argument("--section", default=SECTION,
                   help=f"the markers' name for --write: <!-- NAME --> lines (default {SECTION})")
    p.add_argument("overrides", nargs="*", help="further Hydra overrides (e.g. budget=8, paths.data_dir=..)")
    args = p.parse_args(argv)
    sigmas = sorted(args.sigmas or SIGMAS)
    if args.write is not None:
        check(args.write, args.section)  # before any rendering or scoring
    if sigmas[0] <= 0:
        p.error(f"--sigma {sigmas[0]}: a blur is a positive number of pixels")
    from mcd.config.compose import compose

    cfg = compose([f"data={args.data}", *args.overrides])
    text = provenance(argv, cfg) + table(cfg, sigmas)
    print(text)
    if args.write is not None:
        write_section(args.write, text, args.section)


if __name__ == "__main__":
    main()

"""How much of a run's error is luminance and how much is colour (notes/colour_error.md).

For each finished run given, over the test frames it saved (``samples/<scene>/<frame>_output.exr`` beside
``_reference.exr``; a run saves a few per scene, so the figures are of those frames, not of ``metrics.json``'s
whole test set), the display PSNR (:func:`mcd.core.metrics.psnr`) of the following. ``--image`` scores another
saved image in place of the output: ``initial`` (a kernel-pool row's ``i_bar``, what ``F_d`` corrects),
``adaptive`` (the adaptive render) or ``noisy``.

- ``as saved``: the output (or ``--image``) as saved;
- ``luminance error only``: the output's luminance with the reference's chromaticity (every pixel's
  colour put right, its brightness left as the method made it);
- ``colour error only``: the reference's luminance with the output's chromaticity;
- ``colour smoothed``: the output's luminance with its own chromaticity averaged over a ``--box`` square
  (a test of whether the colour error is pixel-sized: smoothing helps only then);
- with ``--hue-from NAME``, ``hue from NAME``: the output's luminance with the chromaticity of another saved
  image of the frame, averaged over the ``--box`` square (``--hue-from initial``: the hue of ``i_bar``, the
  kernel pool's filter of the adaptive render, in place of the one ``F_d``'s correction gave).

Luminance is Rec. 709's ``Y``; a pixel's chromaticity is ``rgb / Y``, taken only where both images have
``Y`` above :data:`DARK` (elsewhere the pixel stays as it is). Also counted: the share of pixels whose
chromaticity, as ``rgb / (r + g + b)``, lies more than :data:`HUE_OFF` from the reference's (L1), among the
pixels where both are above :data:`DARK`. A table in Markdown, one row per run (``--per-scene``: one per run
and scene)::

    PYTHONPATH=. python tools/colour_split.py RUN_DIR [RUN_DIR ...] [--box 5] [--per-scene] [--image output]
        [--hue-from initial]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from mcd.models.hue import DARK  # the output step's own dark floor
from mcd.models.inputs import LUMA  # and luminance weights

#: L1 distance of ``rgb / (r + g + b)`` from the reference's above which a pixel counts as off in hue.
HUE_OFF = 0.1
#: The saved images ``--image`` scores (mcd.lit.samples; ``initial`` is a kernel-pool row's ``i_bar``).
IMAGES = ("output", "initial", "adaptive", "noisy")
COLUMNS = ("as saved", "luminance error only", "colour error only", "colour smoothed")


def luminance(image: np.ndarray) -> np.ndarray:
    """``H x W x 1`` Rec. 709 luminance of linear ``H x W x 3`` RGB."""
    return (image @ np.asarray(LUMA))[..., None]


def recombine(lum_from: np.ndarray, colour_from: np.ndarray) -> np.ndarray:
    """``lum_from``'s luminance with ``colour_from``'s chromaticity, where both are above :data:`DARK`;
    ``lum_from`` itself elsewhere."""
    y_l, y_c = luminance(lum_from), luminance(colour_from)
    ok = (y_l > DARK) & (y_c > DARK)
    return np.where(ok, y_l * colour_from / np.where(ok, y_c, 1.0), lum_from)


def smooth_colour(image: np.ndarray, box: int, hue: np.ndarray | None = None) -> np.ndarray:
    """``image``'s luminance with the chromaticity of ``hue`` (default: ``image`` itself) averaged over a
    ``box`` x ``box`` square (the box mean of the RGB, whose chromaticity is the luminance-weighted mean of
    the pixels')."""
    from scipy.ndimage import uniform_filter

    hue = image if hue is None else hue
    return recombine(image, uniform_filter(hue, size=(box, box, 1), mode="reflect"))


def hue_off_share(output: np.ndarray, ref: np.ndarray) -> float:
    """Share of the pixels lit in both (luminance above :data:`DARK`) whose chromaticity is off by more
    than :data:`HUE_OFF`."""
    lit = ((luminance(output) > DARK) & (luminance(ref) > DARK))[..., 0]
    if not lit.any():
        return 0.0
    chroma = [x[lit] / x[lit].sum(-1, keepdims=True) for x in (output, ref)]
    return float((np.abs(chroma[0] - chroma[1]).sum(-1) > HUE_OFF).mean())


def frame_figures(output: np.ndarray, ref: np.ndarray, box: int,
                  hue_from: tuple[str, np.ndarray] | None = None) -> dict[str, float]:
    """The module docstring's PSNRs and hue-off share of one frame (linear ``H x W x 3``; the output's
    negative values are taken as 0, as the display image does); ``hue_from``: ``(name, image)`` of the
    ``hue from`` column."""
    from mcd.core.metrics import psnr

    output = np.maximum(output.astype(np.float64), 0.0)
    ref = ref.astype(np.float64)
    images = (output, recombine(output, ref), recombine(ref, output), smooth_colour(output, box))
    found = {k: psnr(x, ref) for k, x in zip(COLUMNS, images, strict=True)}
    if hue_from is not None:
        name, hue = hue_from
        hue = np.maximum(hue.astype(np.float64), 0.0)
        found[f"hue from {name}"] = psnr(smooth_colour(output, box, hue), ref)
    return {**found, "hue off %": 100.0 * hue_off_share(output, ref)}


def run_frames(run_dir: Path, image: str = "output") -> list[tuple[str, Path, Path]]:
    """``(scene, image, reference)`` of every saved test frame of ``run_dir``; ValueError naming the folder
    when it saved none."""
    found = [(o.parent.name, o, o.with_name(o.name.replace(f"_{image}.exr", "_reference.exr")))
             for o in sorted((run_dir / "samples").glob(f"*/*_{image}.exr"))]
    found = [f for f in found if f[2].is_file()]
    if not found:
        raise ValueError(f"{run_dir}/samples holds no <frame>_{image}.exr with its _reference.exr: give a "
                         "finished run directory (its test saves a few frames of each scene there) and an "
                         "image it saved")
    return found


def measure(run_dir: Path, box: int, per_scene: bool, image: str = "output",
            hue_from: str | None = None) -> list[dict]:
    """One row per run (or per run and scene): the mean of :func:`frame_figures` of ``image`` over the saved
    frames; ValueError naming the file where a frame lacks the ``hue_from`` image."""
    from mcd.data.exr import read_exr

    by_key: dict[str, list[dict[str, float]]] = {}
    for scene, out, ref in run_frames(run_dir, image):
        key = scene if per_scene else "all"
        hue = None
        if hue_from is not None:
            path = out.with_name(out.name.replace(f"_{image}.exr", f"_{hue_from}.exr"))
            if not path.is_file():
                raise ValueError(f"{path} is missing: --hue-from {hue_from} needs that image of every saved "
                                 "frame (a kernel-pool row saves `initial`)")
            hue = (hue_from, read_exr(path))
        by_key.setdefault(key, []).append(frame_figures(read_exr(out), read_exr(ref), box, hue))
    rows = []
    for key, frames in by_key.items():
        mean = {k: float(np.mean([f[k] for f in frames])) for k in frames[0]}
        rows.append({"run": run_dir.name, "image": image, "scenes": key, "frames": len(frames), **mean,
                     "dB the colour costs": mean["luminance error only"] - mean["as saved"]})
    return rows


def table(rows: list[dict]) -> str:
    """The rows as a Markdown table, PSNRs in dB to two decimals."""
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for row in rows:
        lines.append("| " + " | ".join(f"{v:.2f}" if isinstance(v, float) else str(v) for v in row.values())
                     + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", type=Path, help="finished run directories with samples/")
    parser.add_argument("--box", type=int, default=5, help="side of the colour-smoothing square (odd)")
    parser.add_argument("--per-scene", action="store_true", help="one row per run and scene")
    parser.add_argument("--image", default="output", choices=IMAGES, help="the saved image scored")
    parser.add_argument("--hue-from", choices=IMAGES, help="add the column: the image's luminance with this "
                        "saved image's chromaticity, box-averaged")
    args = parser.parse_args(argv)
    if args.box < 1 or args.box % 2 == 0:
        parser.error(f"--box {args.box}: give an odd side of at least 1")
    try:
        rows = [row for run in args.runs
                for row in measure(run, args.box, args.per_scene, args.image, args.hue_from)]
    except ValueError as exc:
        parser.error(str(exc))
    print(table(rows))


if __name__ == "__main__":
    main()

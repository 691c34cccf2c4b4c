"""Qualitative strips per scene (docs/benchmark.md "Reports"): noisy input, sampling map, kernel map, initial
denoise `ī`, output, its FLIP error map and reference of the full method, with zoomed crops; and a second
strip comparing every method's output on the same crop, with its FLIP error map below. Read from the runs'
`samples/<scene>/<frame:04d>_<name>.exr` (written by `mcd.lit.samples`, pictured by its `picture`)."""

from __future__ import annotations

import logging
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from mcd.config.methods import (
    BY_EXPERIMENT,  # noqa: E402
    display_name,  # noqa: E402
)
from mcd.core.metrics import flip_map, to_display  # noqa: E402
from mcd.core.paths import SAFE_NAME  # noqa: E402
from mcd.data.exr import CorruptEXRError, EXRLayoutError, EXRSizeError, read_exr  # noqa: E402
from mcd.lit.samples import picture  # noqa: E402
from mcd.reporting.outputs import writes  # noqa: E402
from mcd.reporting.provenance import Provenance  # noqa: E402
from mcd.reporting.runs import Run  # noqa: E402
from mcd.reporting.select import pick  # noqa: E402
from mcd.reporting.tables import COMPONENT_ROWS, TABLE1_BUDGET, TABLE1_ROWS, table1_experiments  # noqa: E402

#: Columns of the strip and their titles (`noisy` is saved as `noisy_<budget>spp`).
COLUMNS = (
    ("noisy", display_name("noisy")),
    ("sampling_map", "sampling map m"),
    ("kernel_index", "kernel index h[0]"),
    ("identity_weight", "identity weight (h[1]+1)/2"),
    ("initial", "initial denoise ī"),
    ("output", "output"),
    ("flip", "FLIP error of the output"),
    ("reference", "reference"),
)
log = logging.getLogger(__name__)
_NAME = re.compile(r"^(?P<frame>\d+)_(?P<name>[a-z_]+?)(?:_\d+spp)?$")

#: What it writes in a report's folder (mcd.reporting.outputs).
DIR, = writes("standard", "strips")


#: The sample EXRs the current report found damaged (:func:`read_sample`), for ``mcd.report`` to name at its
#: end (``mcd.report.make_report`` empties it first).
UNREADABLE: dict[Path, str] = {}


def read_sample(path: Path) -> np.ndarray | None:
    """A run's saved sample, or None (logged, and kept in :data:`UNREADABLE`) where it does not decode: one
    damaged EXR in a run's ``samples/`` ended the report in a traceback after its tables, half written."""
    try:
        return read_exr(path)
    except (CorruptEXRError, EXRLayoutError, EXRSizeError) as err:
        UNREADABLE[path] = str(err)
        log.error("%s: a damaged sample, left out of the strips and the viewer", path)
        return None


def samples(run: Run) -> dict[str, dict[int, dict[str, Path]]]:
    """`scene -> frame -> name -> EXR path` of a run's saved samples."""
    found: dict[str, dict[int, dict[str, Path]]] = {}
    root = run.path / "samples"
    if not root.is_dir():
        return found
    for exr in sorted(root.glob("*/*.exr")):
        m = _NAME.match(exr.stem)
        if m and not exr.is_file():  # a FIFO or a device (a link to /dev/zero): waited on or read for ever
            UNREADABLE[exr] = f"{exr}: not a regular file"
            log.error("%s: not a regular file, left out of the strips and the viewer", exr)
        elif m and not SAFE_NAME.fullmatch(exr.parent.name):  # a scene names the report's files
            log.warning("%s: the scene folder's name is not a plain name (letters, digits, '_', '-', '.'): "
                        "left out of the strips and the viewer", exr)
        elif m:
            found.setdefault(exr.parent.name, {}).setdefault(int(m["frame"]), {})[m["name"]] = exr
    return found


def crop_box(noisy: np.ndarray, ref: np.ndarray, size: int) -> tuple[int, int]:
    """Top-left (y, x) of the `size` x `size` window where the noisy input's display error is largest."""
    err = np.abs(to_display(noisy) - to_display(ref)).mean(axis=-1)
    h, w = err.shape
    if size >= min(h, w):
        return 0, 0
    integral = np.pad(err.cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    sums = (
        integral[size:, size:] - integral[:-size, size:] - integral[size:, :-size] + integral[:-size, :-size]
    )
    y, x = np.unravel_index(int(np.argmax(sums)), sums.shape)
    return int(y), int(x)


def strip_run(runs: list[Run]) -> Run | None:
    """The run whose samples make the strip (and the viewer's frames, mcd.reporting.viewer): F at 4 spp, else
    the first component row with samples."""
    for exp in ("F", *COMPONENT_ROWS):
        run = pick(runs, exp, TABLE1_BUDGET, prefer_sweep="ablation")
        if run is not None and run.status == "ok" and samples(run):
            return run
    return None


def table1_runs(runs: list[Run], variants: bool = False) -> list[tuple[str, str, Run]]:
    """``(experiment, title, run)`` of Table 1's finished methods at 4 spp, in Table 1's order, the noisy
    input left out (the strips and the viewer show it from the full method's samples). A method's stand-in
    (mcd.config.methods: row A for the U-Net) stands in where it did not run (as in table1), under the same
    title. ``variants``: each row is followed by its variants that ran (``table1_experiments``: F_paper after
    F, as Table 1 lists them); the strips, of fixed width, leave them out."""
    found = []
    rows = table1_experiments({r.experiment for r in runs}) if variants else TABLE1_ROWS
    for exp in (e for e in rows if e != "noisy"):
        other = pick(runs, exp, TABLE1_BUDGET, prefer_sweep="baselines")
        title = display_name(exp)
        alt = BY_EXPERIMENT[exp].stand_in
        if alt is not None and (other is None or other.status != "ok"):
            exp, title = alt, f"{title} (row {alt})"
            other = pick(runs, alt, TABLE1_BUDGET, prefer_sweep="ablation")
        if other is not None and other.status == "ok":
            found.append((exp, title, other))
    return found


def flip_picture(image: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, float]:
    """The FLIP error map of ``image`` against ``ref`` in the magma colours (0 black .. 1 white, as FLIP's own
    pictures) and its mean."""
    err = flip_map(image, ref)
    return plt.get_cmap("magma")(err)[..., :3], float(err.mean())


def _show(ax: plt.Axes, image: np.ndarray, title: str | None = None) -> None:
    ax.imshow(image, interpolation="nearest")
    ax.set_xticks([])
    ax.set_yticks([])
    if title:
        ax.set_title(title, fontsize=8)


def write(runs: list[Run], out_dir: Path, prov: Provenance) -> list[Path]:
    """`strips/<scene>.png` (the full method's stages) and `strips/<scene>_methods.png` (every method's output
    on the same crop); returns the written paths."""
    run = strip_run(runs)
    folder = out_dir / DIR
    folder.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    if run is None:
        return written
    others = [(title, samples(other)) for _, title, other in table1_runs(runs)]
    for scene, frames in sorted(samples(run).items()):
        complete = [f for f, names in frames.items() if "output" in names and "reference" in names]
        if not complete:
            continue
        frame = min(complete)
        names = frames[frame]
        imgs = {name: img for name, path in names.items() if (img := read_sample(path)) is not None}
        if "output" not in imgs or "reference" not in imgs:
            continue
        if "kernel_map" in imgs:  # its two channels as two colour maps (paper Sec. 4.1)
            imgs["kernel_index"] = imgs["identity_weight"] = imgs["kernel_map"]
        ref = imgs["reference"]
        flip_pic, flip_mean = flip_picture(imgs["output"], ref)
        size = max(8, min(ref.shape[:2]) // 4)
        y, x = crop_box(imgs.get("noisy", imgs["output"]), ref, size)
        cols = [(n, t) for n, t in COLUMNS if n in imgs or n == "flip"]  # FLIP is computed, not saved
        fig, axes = plt.subplots(2, len(cols), figsize=(2.4 * len(cols), 5.4), squeeze=False)
        for j, (name, title) in enumerate(cols):
            pic = flip_pic if name == "flip" else picture(name, imgs[name])
            if name == "flip":
                title = f"{title} (mean {flip_mean:.3f})"
            if name == "sampling_map":
                m = imgs[name][..., 0]
                title = f"{title} ({m.min():.0f}..{m.max():.0f}, mean {m.mean():.2f})"
            if name == "identity_weight":
                title = f"{title} (mean {(imgs[name][..., 1].mean() + 1) / 2:.2f})"
            _show(axes[0, j], pic, title)
            axes[0, j].add_patch(Rectangle((x - 0.5, y - 0.5), size, size, fill=False, ec="red", lw=1))
            _show(axes[1, j], pic[y : y + size, x : x + size])
        fig.suptitle(
            f"{display_name(run.experiment)} at {run.budget:g} spp, {scene}, test frame {frame} "
            f"({run.path.name})",
            fontsize=9,
        )
        path = prov.save(fig, folder / f"{scene}.png")
        written.append(path)
        if "kernel_pool" in imgs:
            fig, ax = plt.subplots(figsize=(8, 4.6))
            _show(ax, picture("kernel_pool", imgs["kernel_pool"]),
                  f"adjusted kernel pool of {scene}, test frame {frame}: 5x5 kernels in index order "
                  f"(largest tap {imgs['kernel_pool'].max():.3f}; a uniform 5x5 box is 0.04)")
            written.append(prov.save(fig, folder / f"{scene}_pool.png"))

        crops = [(display_name("noisy"), imgs["noisy"])] if "noisy" in imgs else []
        for title, smp in others:
            exr = smp.get(scene, {}).get(frame, {}).get("output")
            image = None if exr is None else read_sample(exr)
            if image is not None and image.shape != ref.shape:  # as the viewer: another size is left out
                log.warning("strips: %s is %s, the reference %s is %s: left out (a run of other data?)", exr,
                            image.shape, names["reference"], ref.shape)
            elif image is not None:
                crops.append((title, image))
        crops.append(("reference", ref))
        fig, axes = plt.subplots(2, len(crops), figsize=(2.2 * len(crops), 5.6), squeeze=False)
        for j, (title, image) in enumerate(crops):
            _show(axes[0, j], picture("output", image)[y : y + size, x : x + size], title)
            err, mean = flip_picture(image, ref)
            _show(axes[1, j], err[y : y + size, x : x + size], f"FLIP, frame mean {mean:.3f}")
        fig.suptitle(
            f"Outputs at 4 spp and their FLIP error maps, {scene}, test frame {frame}, "
            f"crop at (x={x}, y={y}), {size}px", fontsize=9
        )
        path = prov.save(fig, folder / f"{scene}_methods.png")
        written.append(path)
    return written

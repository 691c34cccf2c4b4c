"""The comparison viewer of a report (docs/benchmark.md "Viewer"): ``<report>/viewer/``, a
static page that opens from disk (``file://``, no server, nothing from the network) and shows, for each test
scene and frame that the runs saved samples of (``train.sample_frames``, ``mcd.lit.samples``):

- every method of Table 1 (``strips.table1_runs``: F, the baselines, OIDN, and the variants that ran, such as
  the paper's exact F; a stand-in where a method did not run) beside the noisy input at the same budget and
  the reference, each with the frame's metrics from its run's ``frames.csv``;
- a wipe between any two pictures (left and right picked from lists), zoom (wheel) and pan (drag) in sync
  across every picture, exposure in stops;
- each picture's FLIP error map against the reference (``mcd.core.metrics.flip_map``, magma colours);
- the full method's sampling map ``m`` and its kernel map (kernel index ``h[0]`` and identity weight, paper
  Sec. 4.1), pictured as the strips picture them (``mcd.lit.samples.picture``).

Bytes: every picture is a lossless 8-bit WebP file (smaller than PNG; lossless, so the noise shows as the
metrics score it). The colour pictures are tone-mapped by ``mcd.core.metrics.to_display`` (what PSNR and FLIP
see) after an exposure of ``2**ev``, one file per stop of :data:`STOPS`, and the page loads only the shown
frame's pictures at the shown stop. Pre-exposed stops keep the page on plain ``<img>`` elements: a continuous
exposure would need float data drawn through a canvas, and Chromium forbids reading back pixels of images from
``file://`` pages, so the floats would have to travel base64-encoded inside scripts (docs/benchmark.md
"Viewer" weighs the two). Error and map pictures do not depend on exposure: one file each. A frame larger
than :data:`MAX_SIDE` on a side is cut to its noisiest :data:`MAX_SIDE` square (``strips.crop_box``). The
viewer holds ``frames x (methods + 2) x len(STOPS)`` colour pictures and ``frames x (methods + 1)`` error
maps; docs/benchmark.md "Viewer" gives measured sizes.

The page is ``index.html``, ``viewer.js`` and ``viewer.css`` (copied from ``mcd/reporting/viewer_page/``)
with the report's data in ``data.js``, which sets ``window.MCD_VIEWER``: a script, because Chromium refuses
``fetch`` of a JSON file from a ``file://`` page. :func:`index_path` tells the reports' index whether a report
has a viewer.
"""

from __future__ import annotations

import json
import logging
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib import colormaps
from PIL import Image

from mcd.config.methods import display_name
from mcd.core.metrics import flip_map, to_display
from mcd.lit.samples import picture
from mcd.reporting.outputs import writes
from mcd.reporting.records import from_own_records
from mcd.reporting.runs import Run
from mcd.reporting.strips import crop_box, read_sample, samples, strip_run, table1_runs

log = logging.getLogger(__name__)

#: The viewer's folder inside a report (every report kind's: mcd.reporting.outputs).
VIEWER_DIR, = writes("both", "viewer")
#: The page's static files, copied into each report's viewer.
PAGE_DIR = Path(__file__).with_name("viewer_page")
#: Exposure stops (EV) of the colour pictures: as scored, then 4x and 16x brighter for the dark regions where
#: the denoisers' defects hide. None below 0: Reinhard's curve already keeps highlights
#: below white.
STOPS = (0, 2, 4)
#: The largest side of a picture in pixels; a larger frame is cut to its noisiest square of this side.
MAX_SIDE = 256
#: Per-frame metrics shown for each picture, as ``frames.csv`` names them (the noisy input's with ``input_``).
METRICS = ("psnr", "ssim", "rmse", "flip")
#: The full method's maps and how they are titled.
MAPS = (
    ("sampling_map", "sampling map m (samples per pixel)"),
    ("kernel_index", "kernel choice h[0] (position along the pool)"),
    ("identity_weight", "identity weight (h[1]+1)/2 (1 = the raw pixel)"),
)


def index_path(report_dir: Path) -> Path | None:
    """The viewer's page of the report at ``report_dir``, or None when the report has no viewer."""
    path = Path(report_dir) / VIEWER_DIR / "index.html"
    return path if path.is_file() else None


def remove(report_dir: Path) -> None:
    """Remove the viewer of the report at ``report_dir``, if it has one (``mcd.report --no-viewer``)."""
    shutil.rmtree(Path(report_dir) / VIEWER_DIR, ignore_errors=True)


def _methods(runs: list[Run], main: Run) -> list[tuple[str, str, Run]]:
    """``(key, title, run)`` of every method to show: Table 1's with the variants that ran
    (``strips.table1_runs``), with the run of the frames (``strips.strip_run``) first when Table 1 lacks
    it."""
    chosen = table1_runs(runs, variants=True)
    if all(run.path != main.path for _, _, run in chosen):
        chosen.insert(0, (main.experiment, display_name(main.experiment), main))
    return chosen


def _frame_metrics(run: Run, scene: str, frame: int, prefix: str = "") -> dict[str, float | None]:
    """The run's ``frames.csv`` metrics of one frame (``prefix="input_"``: its noisy input's); None where
    absent."""
    df = run.frames
    found: dict[str, float | None] = dict.fromkeys(METRICS)
    if df is None or "scene" not in df or "frame" not in df:
        return found
    rows = df[(df["scene"].astype(str) == scene) & (df["frame"] == frame)]
    if rows.empty:
        return found
    for key in METRICS:
        col = prefix + key
        if col in rows:
            value = float(rows.iloc[0][col])
            found[key] = value if math.isfinite(value) else None
    return found


def _save(pixels: np.ndarray, folder: Path, name: str) -> str:
    """Write an ``H x W x 3`` picture in [0, 1] as an 8-bit lossless WebP at ``folder/name``; returns
    ``name``."""
    path = folder / name
    path.parent.mkdir(parents=True, exist_ok=True)
    pixels = np.nan_to_num(np.clip(pixels, 0.0, 1.0), nan=0.0)
    image = Image.fromarray(np.round(pixels * 255).astype(np.uint8))
    image.save(path, format="WEBP", lossless=True, quality=100)
    return name


def _frame(folder: Path, scene: str, frame: int, colour: list[tuple[str, str, np.ndarray, dict]],
           maps: dict[str, np.ndarray]) -> dict[str, Any]:
    """Write one frame's pictures under ``folder/img/<scene>/<frame>/`` and return its entry of data.js."""
    ref = colour[-1][2]
    h, w = ref.shape[:2]
    side = min(MAX_SIDE, h, w)
    y, x = (0, 0) if max(h, w) <= MAX_SIDE else crop_box(colour[0][2], ref, side)
    ch, cw = (h, w) if max(h, w) <= MAX_SIDE else (side, side)
    here = f"img/{scene}/{frame:04d}"
    images = []
    for key, title, image, metrics in colour:
        entry: dict[str, Any] = {"key": key, "title": title, "metrics": metrics, "stops": [
            _save(to_display(image[y:y + ch, x:x + cw].astype(np.float64) * 2.0**ev), folder,
                  f"{here}/{key}_ev{ev:+d}.webp")
            for ev in STOPS
        ]}
        if key != "reference":
            err = flip_map(image, ref)[y:y + ch, x:x + cw]
            src = _save(colormaps["magma"](err)[..., :3], folder, f"{here}/{key}_flip.webp")
            entry["flip"] = {"src": src, "mean": float(err.mean())}
        images.append(entry)
    shown = []
    for name, title in MAPS:
        if name in maps:
            values = maps[name][y:y + ch, x:x + cw]
            if name == "sampling_map":
                m = values[..., 0]
                note = f"{m.min():.0f}..{m.max():.0f}, mean {m.mean():.2f}"
            elif name == "kernel_index":
                note = f"std {values[..., 0].std():.3f}"
            else:
                note = f"mean {(values[..., 1].mean() + 1) / 2:.3f}"
            shown.append({"key": name, "title": title, "note": note,
                          "src": _save(picture(name, values), folder, f"{here}/{name}.webp")})
    return {"scene": scene, "frame": frame, "width": cw, "height": ch, "full": [w, h], "crop": [x, y],
            "images": images, "maps": shown}


def write(runs: list[Run], out_dir: Path, name: str) -> Path | None:
    """Write ``out_dir/viewer/`` for the report ``name`` (see the module docstring) and return its page.

    Where no finished run saved samples: a report regenerated from its own run records (which keep none,
    :func:`mcd.reporting.records.from_own_records`) leaves an earlier viewer as it was, as the strips are, and
    returns its page (None without one); any other report removes it and returns None (a report of other runs
    under the same name kept the earlier runs' viewer and linked it as its own). Otherwise the viewer is
    written whole, anew, beside the old one, which it then replaces: it holds only what these runs saved, and
    a failure half-way leaves the old one whole."""
    folder = out_dir / f".{VIEWER_DIR}.partial"
    main = strip_run(runs)
    complete = [] if main is None else [
        (scene, frame, names) for scene, by_frame in sorted(samples(main).items())
        for frame, names in sorted(by_frame.items()) if "output" in names and "reference" in names]
    if not complete:
        if from_own_records(runs, out_dir):
            return index_path(out_dir)
        remove(out_dir)
        return None
    assert main is not None
    shutil.rmtree(folder, ignore_errors=True)
    methods = [(key, title, run, samples(run)) for key, title, run in _methods(runs, main)]
    frames = []
    for scene, frame, names in complete:
        colour: list[tuple[str, str, np.ndarray, dict]] = []
        ref = read_sample(names["reference"])
        if ref is None:  # damaged: named by mcd.report at its end
            continue
        noisy = read_sample(names["noisy"]) if "noisy" in names else None
        if noisy is not None:
            colour.append(("noisy", f"{display_name('noisy')} ({main.budget:g} spp)",
                           noisy, _frame_metrics(main, scene, frame, prefix="input_")))
        for key, title, run, smp in methods:
            exr = smp.get(scene, {}).get(frame, {}).get("output")
            image = None if exr is None else read_sample(exr)
            if image is not None and image.shape != ref.shape:
                log.warning("viewer: %s is %s, the reference %s is %s: left out (a run of another "
                            "data profile?)", exr, image.shape, names["reference"], ref.shape)
            elif image is not None:
                colour.append((key, title, image, _frame_metrics(run, scene, frame)))
        colour.append(("reference", "reference", ref, dict.fromkeys(METRICS)))
        maps = {}
        if "kernel_map" in names and (kernel := read_sample(names["kernel_map"])) is not None:
            maps["kernel_index"] = maps["identity_weight"] = kernel
        if "sampling_map" in names and (sampling := read_sample(names["sampling_map"])) is not None:
            maps["sampling_map"] = sampling
        frames.append(_frame(folder, scene, frame, colour, maps))
    for page in sorted(PAGE_DIR.iterdir()):
        if page.is_file():
            shutil.copy(page, folder / page.name)
    data = {"report": name, "method": display_name(main.experiment), "stops": list(STOPS),
            "metrics": list(METRICS), "frames": frames}
    (folder / "data.js").write_text(
        "// The report's pictures and metrics for index.html (mcd.reporting.viewer); generated.\n"
        f"window.MCD_VIEWER = {json.dumps(data, separators=(',', ':'))};\n"
    )
    final = out_dir / VIEWER_DIR
    if final.exists():
        shutil.rmtree(final)
    folder.rename(final)
    return final / "index.html"

"""Border artefacts separated from content: the edge effect (docs/benchmark.md "Metrics", "Edge effect").

The border gap of ``mcd.core.metrics`` compares a frame's outer 4 pixels with its interior, so it also
measures how hard the content there is (on ``cbox`` the 1-2 pixel black frame around the box makes every
denoiser's border worse than its interior, OIDN's included). The edge effect asks the question the padding of
a network actually raises: are pixels denoised worse *because* they lie at the image border?

Each test frame is denoised twice: whole, and cut to an inset crop (``margin`` pixels off each side, every
input buffer alike, so the crop is a smaller frame of the same render). The crop's outer ``width``-pixel
frame lies at the image border in the second run and ``margin`` pixels inside the image in the first. The
edge effect is the PSNR (display images, against the reference) of those pixels as the crop's border minus
their PSNR as interior pixels of the whole frame, in dB. 0: the image border costs nothing; below 0: border
artefacts (padding of the U-Nets, the sampling map or the kernels at the border). With adaptive sampling the
crop also spends its samples differently (the map is normalised over the crop), which is part of what a
frame of that size gets. ``tests/models/test_bundled_f.py`` holds the bundled F to it on rendered frames.

For finished runs (after the fact, from the checkpoint the run tested; no retraining)::

    PYTHONPATH=. python tools/edge_effect.py RUN_DIR [RUN_DIR ...] [--margin 16]

writes ``edges.json`` into each run directory (per frame, per scene and over scenes, averaged as
``mcd.core.metrics.aggregate`` does; with the command, the commit and the weights: the checkpoint the run
tested, or for a transfer job tested as loaded the weights it started from). The whole frames must score the
run's own PSNR within ``PSNR_AGREEMENT_DB``, else nothing is written for that run. ``mcd.report`` reads the
file into the ``edge effect`` column of every table. ``scripts/current_report.sh report`` runs it on every
job.
"""

from __future__ import annotations

import argparse
import json
import math
import shlex
import sys
from collections.abc import Iterable
from pathlib import Path
from typing import TYPE_CHECKING

import torch
from omegaconf import OmegaConf
from torch import Tensor

from mcd.core.metrics import BORDER, aggregate, border_psnr, colour_shift, psnr
from mcd.core.provenance import short_commit
from mcd.reporting.runs import EDGES_FILE, MAP_KEYS

if TYPE_CHECKING:
    from mcd.lit.module import DenoiseModule

#: Pixels cut off each side of a frame for its inset crop (more than the ``BORDER`` frame that is compared).
MARGIN = 16
#: How far the whole frames' PSNR here may be from the run's own (measured under the run's precision).
PSNR_AGREEMENT_DB = 0.1


def inset_batch(batch: dict[str, object], margin: int = MARGIN) -> dict[str, object]:
    """``batch`` with every image tensor (``[..., H, W]``, 4-D or more) cut by ``margin`` pixels on each
    side."""
    if margin < 1:
        raise ValueError(f"margin={margin}: give at least 1 pixel")

    def cut(v: object) -> object:
        if isinstance(v, Tensor) and v.ndim >= 4:
            h, w = v.shape[-2:]
            if min(h, w) - 2 * margin < 3 * BORDER:
                raise ValueError(f"a {w}x{h} frame is too small for a {margin}-pixel inset and a "
                                 f"{BORDER}-pixel border frame: give a smaller margin (--margin)")
            return v[..., margin:h - margin, margin:w - margin]
        return v

    return {k: cut(v) for k, v in batch.items()}


def measure(module: DenoiseModule, batches: Iterable[dict[str, object]], margin: int = MARGIN,
            width: int = BORDER, precision: str = "32-true") -> list[dict[str, object]]:
    """Per test frame (the datamodule's test batches, in order): scene, frame, the whole frame's PSNR, its
    noisy input's and its colour shift, and the edge effect (module docstring) with ``margin`` and ``width``.

    The whole frames run first, then the crops (``DenoiseModule.test_step`` resets a temporal model at each
    sequence start), so neither run sees the other's temporal state. ``precision="bf16-mixed"`` runs them
    under bf16 autocast on the CPU, as a run with that precision tested: an adaptive model's integer sampling
    map rounds from its logits, so fp32 and bf16 logits can draw different samples, and the scores of the two
    precisions differ."""
    from mcd.lit.test_recorder import hwc

    module.eval()
    batches = list(batches)
    bf16 = precision.startswith("bf16")
    with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
        whole = [module.test_step(b, i) for i, b in enumerate(batches)]
        crops = [module.test_step(inset_batch(b, margin), i) for i, b in enumerate(batches)]
    rows: list[dict[str, object]] = []
    for full, crop in zip(whole, crops, strict=True):
        out, ref = hwc(full["outputs"]["output"][0]), hwc(full["ref"])
        crop_out, crop_ref = hwc(crop["outputs"]["output"][0]), hwc(crop["ref"])
        h, w = out.shape[:2]
        same_pixels = out[margin:h - margin, margin:w - margin]
        row = {"scene": full["scene"], "frame": full["frame"], "psnr": psnr(out, ref),
               "input_psnr": psnr(hwc(full["noisy"]), ref), "colour_shift": colour_shift(out, ref),
               "edge_effect": border_psnr(crop_out, crop_ref, width)
               - border_psnr(same_pixels, crop_ref, width)}
        row.update(map_border(full["outputs"]))
        rows.append(row)
    return rows


def _ring(x: Tensor) -> tuple[Tensor, Tensor]:
    """The outermost pixel ring of ``[..., H, W]`` and the interior 8 or more pixels from the border."""
    ring = torch.cat([x[..., 0, :], x[..., -1, :], x[..., 1:-1, 0], x[..., 1:-1, -1]], -1)
    return ring, x[..., 8:-8, 8:-8]


def map_border(outputs: dict[str, Tensor]) -> dict[str, float]:
    """What a two-stage model's maps do on the outermost pixel ring (docs/benchmark.md "Metrics", edge
    effect): ``map_border_ratio``, the sampling map's mean there over its interior mean (1: no border
    preference; the ring holds ``4 (W - 1) / (W H)`` of the pixels), and ``index_border`` /
    ``index_interior``, the kernel index ``h[0]``'s mean there and inside (docs/kernel_pool.md)."""
    found: dict[str, float] = {}
    m = outputs.get("sampling_map")
    if m is not None and min(m.shape[-2:]) > 16:
        ring, inner = _ring(m.float())
        found["map_border_ratio"] = float(ring.mean() / inner.mean().clamp_min(1e-12))
    k = outputs.get("kernel_map")
    if k is not None and min(k.shape[-2:]) > 16:
        ring, inner = _ring(k[:, 0].float())
        found["index_border"], found["index_interior"] = float(ring.mean()), float(inner.mean())
    return found


def measure_run(run_dir: Path, margin: int = MARGIN) -> dict[str, object]:
    """The edge effect of a finished run (``metrics.json``) on its test frames (``resolved_config.yaml``),
    with the weights it tested: its checkpoint; a transfer job tested as loaded, ``transfer.init_from``; a
    method without weights (OIDN, the noisy input), as built. Returns the ``edges.json`` record."""
    from mcd.data import StoreBuilder
    from mcd.data.buffers import run_buffers
    from mcd.data.datamodule import MCDDataModule
    from mcd.denoise.weights import load
    from mcd.lit.module import DenoiseModule
    from mcd.models import build

    metrics_file = run_dir / "metrics.json"
    if not metrics_file.is_file():
        raise FileNotFoundError(f"{metrics_file}: not a finished run of python -m mcd.run (no metrics.json); "
                                "give a run directory whose job finished")
    run_metrics = json.loads(metrics_file.read_text())
    tested = run_metrics.get("checkpoint")
    cfg = OmegaConf.load(run_dir / "resolved_config.yaml")  # its test frames (a transfer job's too)
    # the weights it tested: its checkpoint; a transfer job tested as loaded, the weights it started from
    weights = tested or OmegaConf.select(cfg, "transfer.init_from", default=None)
    if weights:
        model = load(str(weights)).model
    elif not cfg.method.get("trainable", True):
        model = build(cfg).eval()
    else:
        raise FileNotFoundError(f"{metrics_file}: names no checkpoint and no transfer.init_from; the weights "
                                "this run tested are unknown")
    store = StoreBuilder.from_cfg(cfg, overrides=[])
    buffers = run_buffers(model.required_buffers(), cfg.budget)
    store.ensure(buffers, progress=False)
    datamodule = MCDDataModule(cfg, store, buffers, model.window)
    datamodule.setup("test")
    rows = measure(DenoiseModule(cfg, model, None), datamodule.test_dataloader(), margin,
                   precision=str(run_metrics.get("precision", "32-true")))
    averages = aggregate(rows, ("edge_effect", "psnr", "colour_shift", *MAP_KEYS))
    if abs(averages["psnr"] - float(run_metrics["psnr"])) > PSNR_AGREEMENT_DB:
        raise RuntimeError(f"{run_dir}: the whole frames score {averages['psnr']:.3f} dB here but "
                           f"{run_metrics['psnr']:.3f} dB in its metrics.json: these are not the weights or "
                           f"frames the run tested ({weights}); nothing written")

    return {"edge_effect": averages["edge_effect"], **{k: averages[k] for k in MAP_KEYS},
            "psnr": averages["psnr"], "per_scene": averages["per_scene"], "frames": rows, "margin": margin,
            "width": BORDER, "checkpoint": tested, "weights": weights,
            "command": shlex.join(["python", "-m", "tools.edge_effect", str(run_dir),
                                   "--margin", str(margin)]),
            "commit": short_commit()}


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="PYTHONPATH=. python tools/edge_effect.py",
                                     description=__doc__.split("\n\n")[0] if __doc__ else None)
    parser.add_argument("runs", nargs="+", type=Path, help="finished run directories of python -m mcd.run")
    parser.add_argument("--margin", type=int, default=MARGIN, help="pixels cut off each side for the crop")
    args = parser.parse_args(argv)
    for run_dir in args.runs:  # check them all before the first long measurement
        if not (run_dir / "metrics.json").is_file():
            parser.error(f"{run_dir}: no metrics.json (not a finished run of python -m mcd.run)")
    failed = []
    for run_dir in args.runs:  # one run that cannot be measured does not stop the others
        try:
            record = measure_run(run_dir, args.margin)
        except (RuntimeError, ValueError, FileNotFoundError) as err:
            print(f"{run_dir}: not measured: {err}", file=sys.stderr)
            failed.append(str(run_dir))
            continue
        (run_dir / EDGES_FILE).write_text(json.dumps(record, indent=1, default=float))
        scenes = ", ".join(f"{k} {v['edge_effect']:+.2f}" for k, v in record["per_scene"].items())
        print(f"{run_dir}: edge effect {record['edge_effect']:+.2f} dB ({scenes})")
        maps = [f"{k} {record[k]:.2f}" for k in MAP_KEYS if not math.isnan(record[k])]
        if maps:
            print(f"{run_dir}: outermost pixel ring: {', '.join(maps)}")
    if failed:
        sys.exit(f"{len(failed)} of {len(args.runs)} run(s) not measured (errors above): {', '.join(failed)}")


if __name__ == "__main__":
    main(sys.argv[1:])

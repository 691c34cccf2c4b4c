"""``python -m mcd.bench loader [--json]`` (or ``--loader``): clips/s of one training-loader worker at the
paper's shapes, the EXR path and the training store measured in one run, warm and cold page cache, with the
worker's memory (docs/training_store.md). The measurement is
:func:`mcd.data.loader_rate.measure`; this command picks the shapes and the buffers, and prints.

Defaults: 1920x1080 frames, 256x256 crops, 5-frame clips, the buffers of ``+experiment=F capacity=paper``
(what
row F's run loads: its model's ``required_buffers()`` plus ``ref`` and the uniform render at the budget),
a synthetic store of 11 frames (about 3 GB of EXR and 2.7 GB packed) written into ``--dir`` (default: a
temporary folder, removed after the run; give a folder to keep the stores for the next run). ``--zarr`` also
measures the chunked, compressed design (needs the ``zarr`` package, not a dependency of mcd). ``--json``
prints one JSON object (the figures of ``measure`` plus ``machine``, ``commit`` and ``loadavg``: the
machine's load averages when the run ended, since the figures are shared-machine figures).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import tempfile
from pathlib import Path

import torch

from mcd.config.compose import compose, experiment_names
from mcd.core.machine import device_name
from mcd.core.paths import CONF_DIR, writable_folder_arg
from mcd.core.provenance import short_commit
from mcd.data.buffers import run_buffers
from mcd.data.loader_rate import measure
from mcd.models import build


def run_buffers_of(experiment: str, capacity: str) -> list[str]:
    """The buffers a run of ``+experiment=<experiment> capacity=<capacity>`` loads."""
    cfg = compose([f"+experiment={experiment}", f"capacity={capacity}"])
    return sorted(run_buffers(build(cfg).required_buffers(), cfg.budget))


def main(argv: list[str] | None = None) -> dict:
    from mcd.denoise.arguments import float_in, int_in  # numbers checked by the parser, naming the flag

    p = argparse.ArgumentParser(prog="python -m mcd.bench loader", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--dir", type=writable_folder_arg("--dir"), default=None,
                   help="folder for the synthetic stores (kept)")
    p.add_argument("--width", type=int_in(1, 16384), default=1920)
    p.add_argument("--height", type=int_in(1, 16384), default=1080)
    p.add_argument("--frames", type=int_in(2, 10**5), default=11,
                   help="frames of the synthetic scene (one test frame)")
    p.add_argument("--crop", type=int_in(1, 16384), default=256)
    p.add_argument("--clip-len", type=int_in(1, 10**5), default=5)
    p.add_argument("--dtype", choices=("float32", "float16"), default="float32")
    p.add_argument("--seconds", type=float_in(0, 3600, lo_open=True), default=5.0,
                   help="timed seconds per figure")
    p.add_argument("--experiment", default="F", help="whose buffers (+experiment=<name>)")
    p.add_argument("--capacity", default="paper", help="capacity profile (conf/capacity/)")
    p.add_argument("--zarr", action="store_true", help="also the Zarr v3 design (needs zarr)")
    args = p.parse_args(argv)
    # every check before the synthetic store (about 3 GB at the defaults) is written
    if args.crop > min(args.width, args.height):
        p.error(f"--crop {args.crop} is larger than the {args.width}x{args.height} frames: give --crop <= "
                f"{min(args.width, args.height)}")
    if args.frames < args.clip_len + 1:
        p.error(f"--frames {args.frames}: one test frame and one clip of --clip-len {args.clip_len} need "
                f"--frames >= {args.clip_len + 1}")
    if args.experiment not in experiment_names():
        p.error(f"--experiment {args.experiment}: no such experiment (conf/experiment: "
                f"{', '.join(sorted(experiment_names()))})")
    if not (CONF_DIR / "capacity" / f"{args.capacity}.yaml").is_file():
        p.error(f"--capacity {args.capacity}: no such capacity profile (conf/capacity: "
                f"{', '.join(sorted(c.stem for c in (CONF_DIR / 'capacity').glob('*.yaml')))})")
    if args.zarr:
        try:
            import zarr  # noqa: F401
        except ImportError as err:
            p.error(f"--zarr needs the zarr package ({err}); pip install zarr")
    buffers = run_buffers_of(args.experiment, args.capacity)
    folder = args.dir or Path(tempfile.mkdtemp(prefix="mcd-loader-bench-"))
    try:
        out = measure(folder, buffers, width=args.width, height=args.height, frames=args.frames,
                      crop=args.crop, clip_len=args.clip_len, dtype=args.dtype, seconds=args.seconds,
                      zarr=args.zarr)
    finally:
        if args.dir is None:
            shutil.rmtree(folder, ignore_errors=True)
    out.update(experiment=args.experiment, machine=device_name(torch.device("cpu")), commit=short_commit(),
               loadavg=list(os.getloadavg()))
    if args.json:
        print(json.dumps(out))
        return out
    s = out["shape"]
    print(f"loader bench: {s['width']}x{s['height']} frames, {s['crop']}x{s['crop']} crops, "
          f"{s['clip_len']}-frame clips, {len(s['buffers'])} buffers ({s['channels']} channels, row "
          f"{args.experiment}), {s['dtype']}; {out['machine']}, load {out['loadavg'][0]:.1f}, "
          f"commit {out['commit']}")
    rows = [("training store, warm", "clips_per_s", "worker_rss_mb"),
            ("training store, cold", "cold_clips_per_s", "cold_worker_rss_mb"),
            ("EXR store", "exr_clips_per_s", "exr_worker_rss_mb")]
    if "zarr_clips_per_s" in out:
        rows.append(("Zarr v3 (Blosc LZ4), warm", "zarr_clips_per_s", "zarr_worker_rss_mb"))
    print(f"{'path':28s} {'clips/s':>9s} {'bound':>7s} {'disk MB/clip':>13s} {'RSS MB':>8s}")
    for name, key, rss in rows:
        disk = out.get("disk_mb_per_clip", {}).get(key)
        print(f"{name:28s} {out[key]:9.2f} {out['bound'][key]:>7s} "
              f"{'' if disk is None else f'{disk:13.1f}':>13s} {out[rss]:8.0f}")
    print(f"training store / EXR: {out['speedup']:.0f}x in this run (goal >= 100x, >= 50 clips/s per worker)")
    return out

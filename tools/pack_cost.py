"""``python tools/pack_cost.py [--checkout DIR ...]``: what packing a training store costs
(:mod:`mcd.data.pack`, docs/training_store.md "Pack: resumable, atomic, verified"), in CPU user and system
seconds and minor page faults, for the ``mcd`` of each checkout given, on one store, in one run.

The store is synthetic (mcd/data/synthetic_store.py: real EXR files, the layout and sizes of a render) and by
default has the shape of the paper smoke (tests/scale/test_paper_smoke.py): 1920x1080, 7 frames (1 test
frame, so 6 packed), row F's 11 buffers (31 channels), float32: a 1.8 GB scene array. Each run is a fresh
interpreter with the checkout on its path that packs the store into a new folder (``pack``), then packs it
again (``check``: every frame found packed, its bytes read back for their CRC-32, as a resumed pack or a
second DDP rank does); each is measured with ``getrusage`` around the call alone (imports excluded). Runs
alternate between the checkouts (``--repeats`` rounds), each after ``--pause`` seconds idle, and the packed
folder is deleted after each; the SHA-256 of every run's scene file is printed, and must be one value.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from omegaconf import OmegaConf

REPO = Path(__file__).resolve().parents[1]
#: row F's buffers (31 channels), as the paper smoke packs them
BUFFERS = ["albedo", "c1", "c16", "c1_in", "c2", "c32", "c4", "c8", "depth", "normal", "ref"]
#: the child: pack twice with the checkout's mcd and print each call's rusage as JSON
CHILD = """
import json, resource, sys, time
from omegaconf import OmegaConf
import mcd
from mcd.core.provenance import short_commit
from mcd.data.pack import pack
from mcd.data.store import StoreReader
cfg = OmegaConf.create(json.load(open(sys.argv[1])))
rows = []
for what in ("pack", "check"):
    reader = StoreReader(cfg.paths.data_dir, cfg.data, overrides=[])
    r0, t0 = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    report = pack(cfg, reader, json.loads(sys.argv[2]))
    r1 = resource.getrusage(resource.RUSAGE_SELF)
    rows.append({"what": what, "user": r1.ru_utime - r0.ru_utime, "sys": r1.ru_stime - r0.ru_stime,
                 "faults": r1.ru_minflt - r0.ru_minflt, "wall": time.perf_counter() - t0,
                 "packed": report["packed"], "reused": report["reused"]})
print(json.dumps({"mcd": mcd.__file__, "commit": short_commit(), "rows": rows}))
"""


def run_once(checkout: Path, cfg_path: Path, buffers: list[str]) -> dict:
    """One child run with ``checkout``'s mcd; its JSON line. SystemExit when it fails or imports another
    checkout's mcd."""
    proc = subprocess.run([sys.executable, "-c", CHILD, str(cfg_path), json.dumps(buffers)], cwd=checkout,
                          env={**os.environ, "PYTHONPATH": str(checkout)}, capture_output=True, text=True,
                          check=False)
    if proc.returncode != 0:
        raise SystemExit(f"error: the pack with {checkout}'s mcd exited {proc.returncode}: "
                         f"{proc.stderr[-2000:]}")
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    if not Path(out["mcd"]).resolve().is_relative_to(checkout.resolve()):
        raise SystemExit(f"error: the child imported {out['mcd']}, not {checkout}'s mcd")
    return out


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        while block := f.read(1 << 24):
            h.update(block)
    return h.hexdigest()


def main(argv: list[str] | None = None) -> None:
    import torch

    from mcd.core.machine import device_name
    from mcd.data.synthetic_store import synthetic_data_cfg, write_synthetic_store

    ap = argparse.ArgumentParser(prog="python tools/pack_cost.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("--checkout", type=Path, action="append",
                    help="a checkout whose mcd packs (repeatable; default: this one)")
    ap.add_argument("--width", type=int, default=1920)
    ap.add_argument("--height", type=int, default=1080)
    ap.add_argument("--frames", type=int, default=7, help="frames of the scene (1 test frame, 1 validation "
                                                          "clip and training clips of 2; default 7)")
    ap.add_argument("--dtype", choices=["float32", "float16"], default="float32")
    ap.add_argument("--repeats", type=int, default=2, help="rounds of one run per checkout (default 2)")
    ap.add_argument("--pause", type=float, default=10.0, help="idle seconds before each run (default 10)")
    ap.add_argument("--tmp", type=Path, help="folder for the store (default: the system's temp folder)")
    args = ap.parse_args(argv)
    checkouts = args.checkout or [REPO]
    with tempfile.TemporaryDirectory(dir=args.tmp) as tmp:
        data_cfg = synthetic_data_cfg("bench", "synth", args.width, args.height, args.frames, clip_len=2,
                                      val_clips=1)
        write_synthetic_store(Path(tmp) / "exr", data_cfg, BUFFERS)
        spec = {"data": OmegaConf.to_container(data_cfg), "paths": {"data_dir": str(Path(tmp) / "exr")}}
        spec["data"]["train_store"] = {"format": "array", "dtype": args.dtype, "dir": str(Path(tmp) / "ts")}
        cfg_path = Path(tmp) / "cfg.json"
        cfg_path.write_text(json.dumps(spec))
        runs: dict[Path, list[dict]] = {c: [] for c in checkouts}
        digests: dict[Path, set[str]] = {c: set() for c in checkouts}
        for _ in range(args.repeats):
            for checkout in checkouts:
                time.sleep(args.pause)
                runs[checkout].append(run_once(checkout, cfg_path, BUFFERS))
                digests[checkout].add(sha256(Path(tmp) / "ts" / "synth.npy"))
                shutil.rmtree(Path(tmp) / "ts")
    print(f"# {args.width}x{args.height}, {args.frames} frames, {len(BUFFERS)} buffers, {args.dtype}; "
          f"{args.repeats} runs per checkout, medians; {device_name(torch.device('cpu'))}; load average "
          f"{os.getloadavg()[0]:.1f} at the end")
    print(f"{'checkout':<28} {'commit':<16} {'call':<6} {'user s':>7} {'sys s':>7} {'CPU s':>7} "
          f"{'faults':>9} {'wall s':>7}  {'CPU s of each run':<20} sha256 of the scene file")
    for checkout in checkouts:
        commit = runs[checkout][0]["commit"]
        for i, what in enumerate(("pack", "check")):
            rows = [r["rows"][i] for r in runs[checkout]]
            med = {k: statistics.median(r[k] for r in rows) for k in ("user", "sys", "faults", "wall")}
            done = {(r["packed"], r["reused"]) for r in rows}
            each = " ".join(f"{r['user'] + r['sys']:.2f}" for r in rows)
            print(f"{str(checkout)[-28:]:<28} {commit:<16} {what:<6} {med['user']:>7.2f} {med['sys']:>7.2f} "
                  f"{med['user'] + med['sys']:>7.2f} {med['faults']:>9.0f} {med['wall']:>7.1f}  {each:<20} "
                  f"{','.join(d[:16] for d in sorted(digests[checkout])) if what == 'pack' else '':<16}  "
                  f"(packed, reused) {sorted(done)}")
    if len({d for ds in digests.values() for d in ds}) != 1:
        raise SystemExit("error: the checkouts' packs wrote different bytes: "
                         + "; ".join(f"{c}: {sorted(d)}" for c, d in digests.items()))
    print("one SHA-256 for every run: the packs wrote the same bytes")


if __name__ == "__main__":
    main()

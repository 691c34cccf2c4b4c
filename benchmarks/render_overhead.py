"""Store throughput against a bare ``mi.render`` of the same images (issue 2; not a test: prints figures).

    python benchmarks/render_overhead.py [--scene staircase2] [--size 64] [--frames 8] [--ref-spp 256]
                                         [--repeats 2]

Both sides load the scene and render the same frames, buffers, spp and seeds with the same box-filter sensor
after a JIT warm-up;
the store additionally writes EXRs atomically, hashes them, computes motion and rewrites the manifest after
each frame. Each side runs `--repeats` times, interleaved, and the fastest run counts (other processes on a
shared machine only ever slow a run down). Because wall-clock differences on a busy machine are noisy, the
time the store spends outside ``mi.render`` (writing, hashing, motion, manifest) is also timed directly and
printed as a share of the bare render time. The store's overhead must stay at or below 10%.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np
from hydra import compose, initialize_config_dir

from mcd.data import BUFFERS, StoreBuilder
from mcd.data import store_builder as store_mod
from mcd.data.camera import interpolate_path
from mcd.data.mitsuba_env import select_variant
from mcd.data.procedural import build_room
from mcd.data.renderer import SceneRenderer, derive_seed
from mcd.data.store import COLOUR_BUFFERS, buffer_spp

CONF = str(Path(__file__).resolve().parents[1] / "conf")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="staircase2")
    ap.add_argument("--size", type=int, default=64)
    ap.add_argument("--frames", type=int, default=8)
    ap.add_argument("--ref-spp", type=int, default=256)
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()

    variant = select_variant("auto")
    overrides = [
        "data=medium",
        f"data.width={args.size}",
        f"data.height={args.size}",
        "data.segments=1",
        f"data.frames_per_segment={args.frames}",
        f"data.ref_spp={args.ref_spp}",
        f"data.train_scenes=[{args.scene}]",
        "data.transfer_scenes=[]",
        f"data.test_scenes=[{args.scene}]",
    ]
    with initialize_config_dir(config_dir=CONF, version_base=None):
        base = compose("config", overrides=overrides)
    data = base.data
    buffers = list(BUFFERS)

    # the bare side: the same scene, sensor, cameras, spp and seeds through mi.render only
    import mitsuba as mi

    spec = StoreBuilder.from_cfg(base).specs[args.scene]
    loaded = spec.load(args.size, args.size, data.max_depth, 1)
    r = SceneRenderer(loaded.scene, args.size, args.size, loaded.fov)
    mats = interpolate_path(loaded.nodes, args.frames)
    aov = mi.load_dict({"type": "aov", "aovs": "dd.y:depth,nn:sh_normal,alb:albedo"})
    seed0 = int(data.seed)

    def bare() -> float:
        t0 = time.perf_counter()
        if spec.kind == "xml":
            scene = mi.load_file(
                str(spec.file), resx=args.size, resy=args.size, max_depth=int(data.max_depth)
            )
        else:
            scene = mi.load_dict(build_room(spec.seed, spec.room, 1, int(data.max_depth))[0])
        sensor = r.sensor
        params = mi.traverse(sensor)
        for f, m in enumerate(mats):
            params["to_world"] = mi.ScalarTransform4f(m.astype(np.float32))
            params.update()
            for b in COLOUR_BUFFERS:
                spp, seed = buffer_spp(b, data), derive_seed(seed0, args.scene, f, b)
                np.asarray(mi.render(scene, sensor=sensor, spp=spp, seed=seed))
            g_seed = derive_seed(seed0, args.scene, f, "gbuffer")
            np.asarray(
                mi.render(scene, sensor=sensor, integrator=aov, spp=int(data.gbuffer_spp), seed=g_seed)
            )
        return time.perf_counter() - t0

    book = {"s": 0.0}

    def timed(fn):
        def wrapper(*a, **k):
            t0 = time.perf_counter()
            try:
                return fn(*a, **k)
            finally:
                book["s"] += time.perf_counter() - t0

        return wrapper

    StoreBuilder._write = timed(StoreBuilder._write)  # EXR write + SHA-256 + manifest entry
    StoreBuilder._save = timed(StoreBuilder._save)  # manifest rewrite after every frame
    store_mod.backward_motion = timed(store_mod.backward_motion)
    store_mod.read_exr = timed(store_mod.read_exr)  # depth read back for motion

    def store_run() -> tuple[float, float]:
        with tempfile.TemporaryDirectory() as tmp:
            with initialize_config_dir(config_dir=CONF, version_base=None):
                cfg = compose("config", overrides=[*overrides, f"paths.data_dir={tmp}"])
            t0 = time.perf_counter()
            summary = StoreBuilder.from_cfg(cfg).ensure(set(buffers), progress=False)
            return time.perf_counter() - t0, summary["msamples"]

    store_run()  # warm-up: JIT kernels of both sides (same kernels)
    bare()
    t_bare, t_store, t_book, msamples = [], [], [], 0.0
    for _ in range(args.repeats):
        t_bare.append(bare())
        book["s"] = 0.0
        t, msamples = store_run()
        t_store.append(t)
        t_book.append(book["s"])
    tb, ts = min(t_bare), min(t_store)
    overhead = ts / tb - 1
    print(
        f"scene {args.scene}, {args.size}x{args.size}, {args.frames} frames, all buffers "
        f"(ref {args.ref_spp} spp), variant {variant}, {msamples:.1f} Msamples per run"
    )
    runs_b = ", ".join(f"{t:.2f}" for t in t_bare)
    runs_s = ", ".join(f"{t:.2f}" for t in t_store)
    verdict = "OK" if overhead <= 0.10 else "OVER"
    print(f"bare mi.render : {tb:7.2f} s  {msamples / tb:6.2f} Msamples/s  (runs: {runs_b})")
    print(f"store.ensure   : {ts:7.2f} s  {msamples / ts:6.2f} Msamples/s  (runs: {runs_s})")
    print(f"store bookkeeping outside mi.render: {min(t_book):.2f} s = {100 * min(t_book) / tb:.1f}% of bare")
    print(
        f"store overhead : {100 * overhead:+.1f}% wall clock ({verdict} against the 10% limit; "
        f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores)"
    )

if __name__ == "__main__":
    main()

"""What checking store checksums costs (``data.verify_checksums``, mcd/data/store.py): load every file of a
store at the ``tiny`` profile's shape (64x64, 32 frames, 2 scenes; the buffers row F reads) through
:class:`mcd.data.store.StoreReader`, once with ``verify_checksums=never`` and once with ``once`` (the
default: SHA-256 on each file's first load in the process), each in a fresh reader, and print the seconds and
the overhead. The store is synthetic (mcd/data/synthetic_store.py): same layout, file sizes and compression
as a render, made in seconds. Usage: ``python tools/checksum_cost.py [--width 64 --height 64]``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from omegaconf import OmegaConf

from mcd.data.store import StoreReader
from mcd.data.synthetic_store import synthetic_data_cfg, write_synthetic_store

BUFFERS = ("ref", "c1", "c4", "albedo", "normal", "depth", "motion")


def load_all(data_dir: Path, cfg, mode: str) -> tuple[float, int]:
    """Seconds to load every file once in a fresh reader under ``verify_checksums=mode``; files loaded."""
    cfg = OmegaConf.merge(cfg, {"verify_checksums": mode})
    reader = StoreReader(data_dir, cfg)
    n = 0
    t0 = time.perf_counter()
    for scene in reader.scene_names:
        for frame in range(reader.frame_count(scene)):
            for buffer in BUFFERS:
                reader.load(scene, frame, buffer)
                n += 1
    return time.perf_counter() - t0, n


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--width", type=int, default=64)
    parser.add_argument("--height", type=int, default=64)
    parser.add_argument("--frames", type=int, default=32)
    parser.add_argument("--repeats", type=int, default=5, help="alternating runs of each mode; medians")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        data_dir = Path(tmp)
        cfgs = []
        for scene in ("cbox", "staircase2"):
            cfg = synthetic_data_cfg("bench", scene, args.width, args.height, args.frames)
            write_synthetic_store(data_dir, cfg, BUFFERS)
            cfgs.append(cfg)
        cfg = OmegaConf.merge(cfgs[0], {"scenes": {**cfgs[0].scenes, **cfgs[1].scenes},
                                        "train_scenes": ["cbox", "staircase2"],
                                        "test_scenes": ["cbox", "staircase2"]})
        mb = sum(p.stat().st_size for p in data_dir.rglob("*.exr")) / 1e6
        times: dict[str, list[float]] = {"never": [], "once": []}
        for _ in range(args.repeats):
            for mode in times:
                seconds, n = load_all(data_dir, cfg, mode)
                times[mode].append(seconds)
    med = {m: sorted(t)[len(t) // 2] for m, t in times.items()}
    print(f"{n} files, {mb:.1f} MB at {args.width}x{args.height}; median of {args.repeats} loads of all:")
    for mode, seconds in med.items():
        print(f"  verify_checksums={mode}: {seconds:.3f} s ({1e3 * seconds / n:.3f} ms/file)")
    print(f"  overhead of checking: {med['once'] - med['never']:.3f} s "
          f"({100 * (med['once'] / med['never'] - 1):.0f}% of loading)")


if __name__ == "__main__":
    main()

"""``python -m mcd.bench``: inference speed of every method (docs/benchmark.md "Metrics", speed), beside
Intel Open Image Denoise on the same frames; prints a table and writes it as CSV with a README beside it, to
``--out`` (default ``outputs/bench/bench.csv`` under the working directory: a measurement never rewrites the
tracked ``reports/bench/bench.csv``, which ``mcd.report``'s speed-against-error plot reads, unless given as
``--out``).

Per method (built by ``mcd.models.build`` from the composed Hydra config ``+experiment=<X>
capacity=<profile>``),
device (CPU; CUDA when present), resolution (1920x1080 and 256x256 by default) and inference path:

- fp32, eager, contiguous; fp32 eager channels-last;
- half precision through ``torch.autocast`` (fp16 and bf16 on CUDA; bf16 on a CPU with native bf16 support),
  channels-last;
- the half paths again after ``torch.compile(mode="max-autotune-no-cudagraphs")`` on CUDA
  (``--no-cuda-compile`` leaves them out: the autotuned builds take minutes per method and size; on CPU only
  with ``--cpu-compile``: inductor's C++ build takes minutes on a small machine).

Timing: one output frame per call (batch 1, under ``torch.inference_mode``) in steady state (temporal methods
keep their state from frame to frame; ``reset()`` once before warm-up), ``--warmup`` calls first, then
``--reps`` timed calls, each closed by ``torch.cuda.synchronize()`` on CUDA; the median and frames/s are
written. CPU at 1080p is slow: it uses ``--cpu-1080p-reps`` (default 2) after ``--cpu-1080p-warmup`` (default
2: with freed memory kept, the heap settles over the first calls), and the CSV's ``warmup`` and ``reps``
columns state them. Beside the time: the method's MACs at that size (``mcd.models.complexity``; for OIDN,
whose network torch cannot see, those of its network's shape: mcd/models/baselines/oidn_network.py) and the
achieved GMAC/s, the torch thread count (OIDN runs its own threads, one per core), and on CPU the process's
peak resident memory during that path's calls (``VmHWM`` of ``/proc/self/status``, reset before the path after
handing freed heap back to the OS; it includes the Python process, the model and the inputs). The README also
gives each device's dense matmul rate (:func:`matmul_ceilings`), the ceiling to read GMAC/s against.
``--allocator keep`` (the default) has glibc keep freed memory for reuse (:mod:`mcd.core.allocator`: without
it every full-frame tensor faults in fresh pages); ``--allocator system`` measures glibc's default; the
``allocator`` column says which ran.

Inputs: the first frame of a test scene read through the store (:meth:`mcd.data.store.StoreReader.load`:
exposure applied, depth scaled, sanitised, as the models see it; ``--data <profile>``, ``--scene``; default
the config's data profile and its first test scene), tiled to the target size; or, with ``--synthetic``,
seeded synthetic buffers (:func:`mcd.data.synthetic.synthetic_frame`). The ``inputs`` column says which.
Unavailable paths (no pyoidn, no bf16 on this CPU) get a row whose ``status`` says why and no time; failures
get ``status`` ``failed: <error>``.

``python -m mcd.bench profile``: the time of each stage of one method (mcd/bench/profile.py,
docs/inference.md); ``python -m mcd.bench train``: training throughput (mcd/bench/train.py).
"""

from __future__ import annotations

import argparse
import csv
import logging
import math
import os
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch
from torch import Tensor, nn

from mcd.config.compose import compose, experiment_names
from mcd.config.methods import CATALOGUE, display_name
from mcd.core import allocator
from mcd.core.config_rules import MAX_SIDE
from mcd.core.machine import device_name, restart_peak_rss, status_mb
from mcd.core.paths import writable_file_arg
from mcd.core.provenance import short_commit
from mcd.data.store import StoreReader
from mcd.data.synthetic import synthetic_frame
from mcd.lit.precision import autocast_to, cpu_bf16_supported
from mcd.models.latency import model_inputs, time_calls

log = logging.getLogger("mcd.bench")

#: The methods measured by default, as the experiments that select them (mcd.config.methods: ``bench``).
METHODS = tuple(m.experiment for m in CATALOGUE if m.bench)
#: Where a measurement goes unless ``--out`` says otherwise (Hydra's ``outputs/``, not a tracked file).
DEFAULT_OUT = Path("outputs/bench/bench.csv")
SIZES = {"1080p": (1080, 1920), "256": (256, 256)}  # or any "<W>x<H>"
COLUMNS = (
    "method",
    "device",
    "dtype",
    "compiled",
    "height",
    "width",
    "ms_median",
    "fps",
    "channels_last",
    "reps",
    "warmup",
    "capacity",
    "inputs",
    "status",
    "device_name",
    "threads",
    "gmacs",
    "gmac_per_s",
    "peak_rss_gb",
    "allocator",
)


@dataclass
class Row:
    """One line of bench.csv (the first eight columns are the interface of docs/architecture.md)."""

    method: str
    device: str
    dtype: str
    compiled: bool
    height: int
    width: int
    ms_median: float | None
    fps: float | None
    channels_last: bool
    reps: int
    warmup: int
    capacity: str
    inputs: str
    status: str
    device_name: str
    threads: int
    gmacs: float | None
    gmac_per_s: float | None = None
    peak_rss_gb: float | None = None
    allocator: str = ""


@dataclass(frozen=True)
class StoreFrame:
    """One stored frame the bench reads its inputs from."""

    store: StoreReader
    scene: str
    frame: int = 0


@dataclass(frozen=True)
class InferencePath:
    """An inference path: autocast dtype (None = fp32), memory format, compilation."""

    dtype: torch.dtype | None
    channels_last: bool
    compiled: bool

    @property
    def dtype_name(self) -> str:
        return "fp32" if self.dtype is None else {torch.float16: "fp16", torch.bfloat16: "bf16"}[self.dtype]


def inference_paths(device: torch.device, cpu_compile: bool,
                    cuda_compile: bool = True) -> list[InferencePath]:
    """The paths measured on `device` (see the module docstring); ``cuda_compile=False`` leaves out the
    compiled CUDA paths (``--no-cuda-compile``)."""
    paths = [InferencePath(None, False, False), InferencePath(None, True, False)]
    if device.type == "cuda":
        halves = [torch.float16] + ([torch.bfloat16] if torch.cuda.is_bf16_supported() else [])
        paths += [InferencePath(h, True, False) for h in halves]
        if cuda_compile:
            paths += [InferencePath(h, True, True) for h in halves]
    else:
        if cpu_bf16_supported():
            paths.append(InferencePath(torch.bfloat16, True, False))
        if cpu_compile:
            paths.append(InferencePath(None, True, True))
    return paths


def store_frame(data: str | None, scene: str | None, frame: int = 0) -> StoreFrame:
    """Frame ``frame`` of ``scene`` (default: the first of ``data.test_scenes``) in the store of data profile
    ``data`` (default: the config's), at ``paths.data_dir``."""
    overrides = [f"data={data}"] if data else []
    cfg = compose(overrides)
    store = StoreReader.from_cfg(cfg, overrides=overrides)
    scene = scene or str(list(cfg.data.test_scenes)[0])
    if scene not in store.specs:
        raise ValueError(f"--scene {scene!r} is not a scene of data profile {store.profile!r} "
                         f"(conf/data/{store.profile}.yaml has {sorted(store.specs)})")
    return StoreFrame(store, scene, frame)


def parse_size(size: str) -> tuple[int, int]:
    """`(height, width)` of a size name (`1080p`, `256`) or `<W>x<H>`."""
    if size in SIZES:
        return SIZES[size]
    try:
        w, h = (int(v) for v in size.lower().split("x"))
    except ValueError:
        raise ValueError(f"size {size!r}: use one of {sorted(SIZES)} or <width>x<height>") from None
    if min(w, h) < 1:
        raise ValueError(f"size {size!r}: width and height must be at least 1")
    if max(w, h) > MAX_SIDE:  # 100000x100000 ended in an allocator's traceback; less might fill the memory
        raise ValueError(f"size {size!r}: a side above {MAX_SIDE} pixels, the largest frame a data profile "
                         "may have (mcd.core.config_rules.MAX_SIDE)")
    return h, w


def _tile(image: np.ndarray, height: int, width: int) -> np.ndarray:
    reps = (math.ceil(height / image.shape[0]), math.ceil(width / image.shape[1]), 1)
    return np.tile(image, reps)[:height, :width]


def frame_buffers(
    names: set[str], height: int, width: int, source: StoreFrame | None
) -> tuple[dict[str, np.ndarray], str]:
    """`H x W x C` float32 buffers by name: a store frame (``StoreReader.load``) tiled to size, else seeded
    synthetic ones (:func:`mcd.data.synthetic.synthetic_frame`, motion of 2 pixels' spread)."""
    if source is not None:
        loaded = {n: source.store.load(source.scene, source.frame, n) for n in sorted(names)}
        h, w = next(iter(loaded.values())).shape[:2] if loaded else (0, 0)
        where = f"store {source.store.profile}/{source.scene} frame {source.frame:04d} ({w}x{h}, tiled)"
        return {n: _tile(b, height, width) for n, b in loaded.items()}, where
    fake = synthetic_frame(names, height, width, lead=(), motion_px=2.0)
    return {n: t.permute(1, 2, 0).numpy() for n, t in fake.items()}, "synthetic (seeded)"


def reset_peak_rss() -> None:
    """Hand freed heap back to the OS (:func:`mcd.core.allocator.hand_back`, so memory an earlier method
    freed does not count) and restart the process's peak resident memory from its current size
    (:func:`mcd.core.machine.restart_peak_rss`)."""
    allocator.hand_back()
    restart_peak_rss()


def peak_rss_gb() -> float | None:
    """The process's peak resident memory (``VmHWM``, :func:`mcd.core.machine.status_mb`) in GB (10^9 bytes)
    since the last :func:`reset_peak_rss`; None where ``/proc`` does not report it."""
    try:
        mb = status_mb("VmHWM")
    except OSError:
        return None
    return None if math.isnan(mb) else mb * 2**20 / 1e9


def bench_one(
    model: nn.Module,
    buffers: dict[str, np.ndarray],
    device: torch.device,
    path: InferencePath,
    warmup: int,
    reps: int,
) -> tuple[float, float | None]:
    """Median ms per frame of `model` on `device` along `path` and the peak resident memory (GB, CPU only)
    during its calls (raises on a non-finite output)."""
    model = model.to(device).eval()
    if path.channels_last:
        model = model.to(memory_format=torch.channels_last)
    fn: Callable[..., dict[str, Tensor]] = model
    if path.compiled:
        fn = torch.compile(model, mode="max-autotune-no-cudagraphs" if device.type == "cuda" else "default")
    x = model_inputs(model, buffers, device, path.channels_last)
    outputs: list[dict[str, Tensor]] = []

    def call() -> None:
        with torch.inference_mode(), autocast_to(device, path.dtype):
            outputs[:] = [fn(x)]

    if hasattr(model, "reset"):
        model.reset()
    reset_peak_rss()
    times = time_calls(call, device, warmup, reps)
    peak = peak_rss_gb() if device.type == "cpu" else None
    out = outputs[0]["output"]
    if not torch.isfinite(out.float()).all():
        raise FloatingPointError(f"non-finite output along {path}")
    return statistics.median(times), peak


def run(
    methods: list[str],
    sizes: list[str],
    devices: list[str],
    overrides: list[str],
    warmup: int,
    reps: int,
    cpu_1080p_warmup: int,
    cpu_1080p_reps: int,
    cpu_compile: bool,
    source: StoreFrame | None,
    cuda_compile: bool = True,
) -> list[Row]:
    """Every (method, device, size, path) measurement (see the module docstring)."""
    from mcd.models import build
    from mcd.models.complexity import complexity

    rows: list[Row] = []
    profile = next((o.split("=", 1)[1] for o in overrides if o.startswith("capacity=")), "cpu")
    for dev_name in devices:
        device = torch.device(dev_name)
        if device.type == "cuda" and not torch.cuda.is_available():
            log.warning("no CUDA device here: skipping the GPU rows")
            continue
        dname = device_name(device)
        paths = inference_paths(device, cpu_compile, cuda_compile)
        for size in sizes:
            h, w = parse_size(size)
            slow = device.type == "cpu" and h * w >= 1080 * 1920
            n_warm, n_reps = (cpu_1080p_warmup, cpu_1080p_reps) if slow else (warmup, reps)
            for method in methods:
                base = dict(
                    method=method,
                    device=device.type,
                    height=h,
                    width=w,
                    warmup=n_warm,
                    reps=n_reps,
                    capacity=profile,
                    device_name=dname,
                    threads=torch.get_num_threads(),
                    allocator=allocator.policy(),
                )
                try:
                    cfg = compose([f"+experiment={method}", *overrides])
                    model = build(cfg)
                    gmacs = complexity(cfg, h, w)[1]
                    base["gmacs"] = None if math.isnan(gmacs) else gmacs
                except Exception as err:  # e.g. OIDN without pyoidn: a row that says so, not a number
                    why = "unavailable" if isinstance(err, ImportError) else "failed to build"
                    rows.append(
                        Row(
                            **{"gmacs": None, **base},
                            dtype="fp32",
                            compiled=False,
                            ms_median=None,
                            fps=None,
                            channels_last=False,
                            inputs="",
                            status=f"{why}: {type(err).__name__}: {(str(err).splitlines() or [''])[0]}",
                        )
                    )
                    log.warning("%s %s: %s", method, why, err)
                    continue
                # a frame missing from the store raises here, naming the render command
                buffers, inputs = frame_buffers(set(model.required_buffers()) - {"ref"}, h, w, source)
                for path in paths:
                    peak = None
                    try:
                        ms, peak = bench_one(model, buffers, device, path, n_warm, n_reps)
                        status, fps = "ok", 1e3 / ms
                    except Exception as err:  # a path that does not work for a method is a row, not a crash
                        ms, fps, status = (
                            None,
                            None,
                            f"failed: {type(err).__name__}: {str(err).splitlines()[0]}",
                        )
                    row = Row(
                        **base,
                        dtype=path.dtype_name,
                        compiled=path.compiled,
                        ms_median=ms,
                        fps=fps,
                        channels_last=path.channels_last,
                        inputs=inputs,
                        status=status,
                        gmac_per_s=None if ms is None or base["gmacs"] is None else base["gmacs"] / ms * 1e3,
                        peak_rss_gb=peak,
                    )
                    rows.append(row)
                    log.info(
                        "%-10s %-4s %4dx%-4d %-4s cl=%d compiled=%d: %s",
                        method,
                        device.type,
                        w,
                        h,
                        path.dtype_name,
                        path.channels_last,
                        path.compiled,
                        f"{ms:.2f} ms ({fps:.2f} fps, {_fmt(row.gmac_per_s, '.1f')} GMAC/s, "
                        f"peak RSS {_fmt(peak, '.2f')} GB)" if ms is not None else status,
                    )
                del model
                if device.type == "cuda":
                    torch.cuda.empty_cache()
    return rows


def matmul_rate(device: torch.device, dtype: torch.dtype, n: int = 2048, reps: int = 5) -> float:
    """GMAC/s of the best of ``reps`` dense ``n x n`` matrix products (``torch.mm``, ``dtype`` inputs) on
    ``device`` with this process's threads: the rate the BLAS reaches here on the best-shaped work, a
    ceiling to read the methods' GMAC/s against (docs/inference.md "OIDN's MACs")."""
    a = torch.randn(n, n, device=device).to(dtype)
    b = torch.randn(n, n, device=device).to(dtype)
    with torch.inference_mode():
        times = time_calls(lambda: torch.mm(a, b), device, warmup=2, reps=reps)
    return n**3 / 1e9 / (min(times) / 1e3)


def matmul_ceilings(devices: list[str]) -> dict[str, float]:
    """:func:`matmul_rate` per available device and dtype of its inference paths (``"cpu fp32"``: GMAC/s)."""
    out: dict[str, float] = {}
    for name in devices:
        device = torch.device(name)
        if device.type == "cuda" and not torch.cuda.is_available():
            continue
        dtypes = {p.dtype_name: p.dtype or torch.float32 for p in inference_paths(device, cpu_compile=False)}
        for dname, dtype in dtypes.items():
            out[f"{device.type} {dname}"] = matmul_rate(device, dtype)
    return out


def load_average() -> float | None:
    """The 1-minute load average (None where the OS does not report it)."""
    try:
        return os.getloadavg()[0]
    except (AttributeError, OSError):
        return None


def _fmt(value: float | None, spec: str) -> str:
    return "" if value is None else format(value, spec)


def write_csv(rows: list[Row], path: Path) -> None:
    """bench.csv with the columns of :data:`COLUMNS` (empty time for unavailable or failed paths)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=COLUMNS)
        writer.writeheader()
        for r in rows:
            d = asdict(r)
            for key, spec in (("ms_median", ".4f"), ("fps", ".5g"), ("gmacs", ".2f"), ("gmac_per_s", ".2f"),
                              ("peak_rss_gb", ".3f")):
                d[key] = _fmt(d[key], spec)
            writer.writerow(d)


#: The most resident memory a method may need at 1080p (docs/inference.md).
MEMORY_LIMIT_GB = 8.0


def summary(rows: list[Row], ceilings: dict[str, float] | None = None) -> list[str]:
    """Markdown lines: the fastest path per method, device and size (time, GMAC/s, peak memory), F's latency
    as a ratio to OIDN's (split into the ratio of their MACs and of their GMAC/s, and the GMAC/s F would need
    to match OIDN, beside the device's dense matmul ``ceilings`` from :func:`matmul_ceilings`), F's GMAC/s as
    a ratio to the U-Net's, and the largest peak memory per size."""
    best: dict[tuple[str, str, int, int], Row] = {}
    for r in rows:
        key = (r.method, r.device, r.height, r.width)
        if r.ms_median is not None and (key not in best or r.ms_median < best[key].ms_median):
            best[key] = r
    lines = [
        "| method | device | size | fastest path | ms/frame | frames/s | GMACs | GMAC/s | peak RSS GB |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for (method, device, h, w), r in sorted(
        best.items(), key=lambda kv: (kv[0][1], -kv[0][2], kv[1].ms_median)
    ):
        path = f"{r.dtype}{' channels-last' if r.channels_last else ''}{' compiled' if r.compiled else ''}"
        lines.append(
            f"| {method} | {device} | {w}x{h} | {path} | {r.ms_median:.2f} | {r.fps:.2f} | "
            f"{_fmt(r.gmacs, '.1f') or '—'} | {_fmt(r.gmac_per_s, '.1f') or '—'} | "
            f"{_fmt(r.peak_rss_gb, '.2f') or '—'} |"
        )
    for bad in (r for r in rows if r.status != "ok"):
        lines.append(
            f"| {bad.method} | {bad.device} | {bad.width}x{bad.height} | {bad.dtype} | — | {bad.status} "
            "| | | |"
        )
    lines.append("")
    for (method, device, h, w), r in sorted(best.items()):
        oidn, unet = best.get(("oidn", device, h, w)), best.get(("unet", device, h, w))
        if method == "F" and oidn is not None:
            lines.append(
                f"- F / {display_name('oidn')} latency on {device} at {w}x{h} (fastest path of each): "
                f"{r.ms_median:.2f} / {oidn.ms_median:.2f} ms = {r.ms_median / oidn.ms_median:.2f}x"
            )
            if r.gmacs and oidn.gmacs and r.gmac_per_s and oidn.gmac_per_s:
                need = r.gmacs / oidn.ms_median * 1e3
                tops = [f"{k.split(' ', 1)[1]} {v:.1f}" for k, v in sorted((ceilings or {}).items())
                        if k.startswith(f"{device} ")]
                lines.append(
                    f"  - = MACs {r.gmacs:.1f} / {oidn.gmacs:.1f} GMACs ({r.gmacs / oidn.gmacs:.2f}x) "
                    f"x GMAC/s {oidn.gmac_per_s:.1f} / {r.gmac_per_s:.1f} "
                    f"({oidn.gmac_per_s / r.gmac_per_s:.2f}x); "
                    f"to match {display_name('oidn')}'s latency F would need {need:.1f} GMAC/s"
                    + (f" (dense matmul here: {', '.join(tops)} GMAC/s)" if tops else "")
                )
        if method == "F" and unet is not None and r.gmac_per_s and unet.gmac_per_s:
            lines.append(
                f"- F / {display_name('unet')} achieved GMAC/s on {device} at {w}x{h} (fastest path of "
                "each): "
                f"{r.gmac_per_s:.1f} / {unet.gmac_per_s:.1f} = {r.gmac_per_s / unet.gmac_per_s:.2f}x"
            )
    for (device, h, w) in sorted({(r.device, r.height, r.width) for r in rows}):
        peaks = [r for r in rows if (r.device, r.height, r.width) == (device, h, w) and r.peak_rss_gb]
        if peaks:
            top = max(peaks, key=lambda r: r.peak_rss_gb or 0.0)
            verdict = "within" if (top.peak_rss_gb or 0.0) <= MEMORY_LIMIT_GB else "ABOVE"
            lines.append(
                f"- Largest peak RSS on {device} at {w}x{h}: {top.method} ({top.dtype}"
                f"{' channels-last' if top.channels_last else ''}) {top.peak_rss_gb:.2f} GB, {verdict} "
                f"the {MEMORY_LIMIT_GB:.0f} GB limit"
            )
    return lines


#: The first line of the README the bench writes beside its CSV.
README_TITLE = "# Inference speed (python -m mcd.bench)"


def check_readme(csv_path: Path) -> str | None:
    """Why the README.md beside ``csv_path`` may not be written (it exists and is not one the bench wrote: a
    user's own README.md in that folder was replaced; or ``--out`` is that README, which the CSV's README
    would replace), or None; asked before anything is measured."""
    if (why := check_csv(csv_path)) is not None:
        return why
    path = csv_path.parent / "README.md"
    if csv_path.name == path.name:
        return (f"--out {csv_path}: the bench writes its README.md beside the CSV, which would replace "
                "the CSV; give the CSV another name")
    if not path.exists():
        return None
    if path.is_file():
        with open(path, encoding="utf-8", errors="replace") as f:
            if f.readline().rstrip("\n") == README_TITLE:
                return None
    return (f"--out {csv_path}: {path} is not a README the bench wrote (its first line is not "
            f"{README_TITLE!r}), and the README written beside the CSV would replace it; give --out in "
            "another folder")


def check_csv(csv_path: Path) -> str | None:
    """Why ``--out`` may not be written: it exists and is not a CSV the bench wrote (its header does not start
    with ``method,device``): a user's own file named as ``--out`` was replaced without a word, exit 0; or
    None. A bench CSV (the tracked ``reports/bench/bench.csv`` among them) is replaced as before."""
    if not csv_path.exists() and not csv_path.is_symlink():
        return None
    if csv_path.is_file() and not csv_path.is_symlink():
        with open(csv_path, encoding="utf-8", errors="replace") as f:
            if f.readline().startswith(f"{COLUMNS[0]},{COLUMNS[1]},"):
                return None
    return (f"--out {csv_path}: exists and is not a CSV the bench wrote (its first line is not the bench's "
            f"header, {COLUMNS[0]},{COLUMNS[1]},...), so the bench would replace it; give --out a new file "
            "or a bench CSV")


def write_readme(rows: list[Row], csv_path: Path, command: str, wall_s: float, commit: str,
                 ceilings: dict[str, float] | None = None, load: tuple[float, float] | None = None) -> Path:
    """README.md beside the CSV: provenance (command, ``commit`` as it was when the run started, device,
    torch, the 1-minute ``load`` average at the run's start and end where known: on a shared machine the
    figures are read against it), the dense matmul ``ceilings`` and :func:`summary`."""
    devices = sorted({f"{r.device}: {r.device_name}" for r in rows})
    inputs = sorted({r.inputs for r in rows if r.inputs})
    reps = sorted({f"{r.device} {r.width}x{r.height}: {r.warmup} warm-up + {r.reps} timed" for r in rows})
    lines = [
        README_TITLE,
        "",
        f"- Command: `{command}`",
        f"- Commit: `{commit}`; torch {torch.__version__}; wall time {wall_s:.0f} s",
        f"- Devices: {'; '.join(devices) or 'none'}",
        *([f"- Load average (1 min) at the start and the end of the run: {load[0]:.1f}, {load[1]:.1f}"]
          if load else []),
        f"- Capacity profile: {', '.join(sorted({r.capacity for r in rows}))}; batch 1, one frame per call",
        f"- Inputs: {', '.join(inputs) or 'none'}",
        f"- Repetitions (median of the timed calls): {'; '.join(reps)}",
        f"- Allocator: {', '.join(sorted({r.allocator for r in rows})) or 'none'} (mcd/core/allocator.py)",
        f"- Data: [{csv_path.name}]({csv_path.name})",
        *(["- Dense matmul ceiling (torch.mm 2048x2048, best of 5, same threads): "
           + ", ".join(f"{k} {v:.1f} GMAC/s" for k, v in sorted(ceilings.items()))] if ceilings else []),
        "",
        *summary(rows, ceilings),
    ]
    path = csv_path.parent / "README.md"
    path.write_text("\n".join(lines) + "\n")
    return path


def main(argv: list[str] | None = None) -> None:
    """The ``speed`` mode of ``python -m mcd.bench`` (mcd/bench/__main__.py): measure, write the CSV and its
    README."""
    from mcd.denoise.arguments import int_in  # counts checked by the parser, naming the flag

    argv = list(sys.argv[1:] if argv is None else argv)
    parser = argparse.ArgumentParser(
        prog="python -m mcd.bench [speed]", description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "overrides", nargs="*", help="Hydra overrides for every method (default: capacity=paper)"
    )
    parser.add_argument("--methods", default=",".join(METHODS), help="experiments, comma-separated")
    parser.add_argument("--sizes", default="1080p,256", help="comma-separated: 1080p, 256 or <W>x<H>")
    parser.add_argument("--devices", default="cpu,cuda", help="cpu and/or cuda (cuda rows need a GPU)")
    parser.add_argument("--warmup", type=int_in(0, 10**6), default=3)
    parser.add_argument("--reps", type=int_in(1, 10**6), default=10)
    parser.add_argument("--cpu-1080p-reps", type=int_in(1, 10**6), default=2,
                        help="timed calls on CPU at 1080p (slow)")
    parser.add_argument("--cpu-1080p-warmup", type=int_in(0, 10**6), default=2,
                        help="warm-up calls on CPU at 1080p (a kept heap settles over the first calls)")
    parser.add_argument(
        "--cpu-compile", action="store_true", help="also torch.compile on CPU (slow to build)"
    )
    parser.add_argument(
        "--no-cuda-compile", action="store_true",
        help="leave out the compiled CUDA paths (max-autotune builds take minutes per method and size)",
    )
    parser.add_argument("--data", help="data profile whose store holds the input frame (default: config's)")
    parser.add_argument("--scene", help="scene of that profile (default: its first test scene)")
    parser.add_argument("--synthetic", action="store_true", help="seeded synthetic inputs, not a store frame")
    parser.add_argument("--out", type=writable_file_arg("--out"), default=str(DEFAULT_OUT),
                        help=f"CSV to write, README.md beside it (default: {DEFAULT_OUT}; the report reads "
                             f"reports/bench/bench.csv)")
    allocator.add_option(parser)
    args = parser.parse_args(argv)
    overrides = list(args.overrides)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    log.info("allocator: %s", allocator.apply(args.allocator))
    if not any(o.startswith("capacity=") for o in overrides):
        overrides.append("capacity=paper")
    if (why := check_readme(args.out)) is not None:
        parser.error(why)
    devices = [d for d in args.devices.split(",") if d]
    if unknown := sorted(set(devices) - {"cpu", "cuda"}):
        parser.error(f"--devices {args.devices}: {', '.join(unknown)} is not a device this bench runs on; "
                     "give cpu and/or cuda")
    methods = [m for m in args.methods.split(",") if m]
    if unknown := sorted(set(methods) - set(experiment_names())):
        parser.error(f"--methods: no experiment {', '.join(unknown)} (conf/experiment: "
                     f"{', '.join(sorted(experiment_names()))})")
    sizes = [s for s in args.sizes.split(",") if s]
    here = [d for d in devices if d != "cuda" or torch.cuda.is_available()]
    for flag, given, value in (("--methods", methods, args.methods), ("--sizes", sizes, args.sizes),
                               ("--devices", here, args.devices)):
        if not given:  # nothing would be measured, and --out would be replaced by an empty table
            why = "torch sees no CUDA device here" if flag == "--devices" and devices else "none given"
            parser.error(f"{flag} {value!r}: {why}, so nothing would be measured (and {args.out} would be "
                         "replaced by an empty table)")
    for s in sizes:
        try:
            parse_size(s)
        except ValueError as err:
            parser.error(str(err))
    commit = short_commit()  # before this run rewrites its own (tracked) report files
    load_start = load_average()
    started = time.perf_counter()
    rows = run(
        methods,
        sizes,
        devices,
        overrides,
        args.warmup,
        args.reps,
        args.cpu_1080p_warmup,
        args.cpu_1080p_reps,
        args.cpu_compile,
        None if args.synthetic else store_frame(args.data, args.scene),
        cuda_compile=not args.no_cuda_compile,
    )
    ceilings = matmul_ceilings(devices)
    for name, rate in sorted(ceilings.items()):
        log.info("dense matmul ceiling %s: %.1f GMAC/s", name, rate)
    write_csv(rows, args.out)
    command = "python -m mcd.bench speed " + " ".join(argv)
    load_end = load_average()
    load = None if load_start is None or load_end is None else (load_start, load_end)
    write_readme(rows, args.out, command, time.perf_counter() - started, commit, ceilings, load)
    print(f"{len(rows)} rows -> {args.out}")


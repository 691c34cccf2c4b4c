"""``mcd-denoise`` / ``python -m mcd.denoise``: denoise your own frames or scene (docs/denoise.md).

    mcd-denoise frames/ -o out/ --checkpoint unet-cpu-small            # (a) EXR frames on disk
    mcd-denoise --scene path/to/scene.xml -o out/ --checkpoint F-cpu-small --width 256 --height 256   # (b)

Every bad input is refused before the long work starts, with a message naming the file and what to do.
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import logging
import sys
from pathlib import Path
from typing import TYPE_CHECKING

from mcd.core import allocator
from mcd.denoise import arguments, output_folder, precision, weights, work
from mcd.denoise.output import SUMMARY, frame_files, write_json
from mcd.denoise.precision import PRECISIONS
from mcd.denoise.reference import MAX_SPP, TARGET_DB

if TYPE_CHECKING:  # torch is imported where used, so that --help starts fast (docs/architecture.md)
    import torch

log = logging.getLogger("mcd.denoise")


def parser() -> argparse.ArgumentParser:
    """The command line; every numeric option has its range (mcd/denoise/arguments.py)."""
    p = argparse.ArgumentParser(prog="mcd-denoise", description=__doc__.split("\n\n")[0],
                                formatter_class=arguments.HelpFormatter,
                                epilog=f"Bundled checkpoints: {', '.join(weights.bundled_names()) or 'none'}")
    p.add_argument("inputs", nargs="*", help="EXR frames of one sequence: a folder, files or a glob pattern "
                   "(layers and sibling files: docs/denoise.md)")
    p.add_argument("-o", "--output", required=True, type=Path, help="output folder")
    p.add_argument("--checkpoint", help="a run directory of python -m mcd.run, a .ckpt file, or a bundled "
                   "name")
    p.add_argument("--experiment", help="the experiment the checkpoint must be of (e.g. unet, F); without "
                   "--checkpoint, a method without weights (oidn, noisy)")
    p.add_argument("--capacity", help="the capacity profile the checkpoint must have (cpu, paper)")
    p.add_argument("--scene", type=arguments.scene_file,
                   help="a Mitsuba 3 scene file to render and denoise (input b)")
    p.add_argument("--width", type=arguments.side, default=None,
                   help="film width (input b; default: the scene's own)")
    p.add_argument("--height", type=arguments.side, default=None,
                   help="film height (input b; default: the scene's own)")
    p.add_argument("--frames", type=arguments.int_in(1, 10**6), default=1,
                   help="scene frames: 1 = its own camera, more = a path derived from it (input b)")
    p.add_argument("--gbuffer-spp", type=arguments.int_in(1, 2**16), default=16,
                   help="samples per pixel of the G-buffers (input b)")
    p.add_argument("--reference-spp", type=arguments.int_in(0, 2**20), default=0,
                   help="score against a reference: its pilot spp on frame 0, raised to --reference-db; 0: "
                   "no scores (input b; docs/denoise.md 'Scores of the real loop')")
    p.add_argument("--reference-db", type=arguments.float_in(0, 100), default=TARGET_DB,
                   help="target of the reference's own estimated PSNR; 0: every reference at --reference-spp "
                   "(input b)")
    p.add_argument("--reference-max-spp", type=arguments.int_in(2, 2**20), default=MAX_SPP,
                   help="cap of the reference's spp (input b)")
    p.add_argument("--exposure", type=arguments.float_in(0, 1e12, lo_open=True), default=None,
                   help="one exposure for the network and every score (frames and scene; default: the "
                   "network's from the first lit frame's input, the scores' from its reference in a scene, "
                   "from it on frames, each mean brought to 0.5)")
    p.add_argument("--seed", type=arguments.int_in(0, 2**32 - 1), default=0, help="render seed (input b)")
    p.add_argument("--device", default="cpu", help="torch device: cpu, cuda, cuda:1, or auto")
    p.add_argument("--precision", default="fp32", choices=list(PRECISIONS),
                   help="network precision: fp32; bf16 (a CPU with native bf16, or a GPU) or fp16 "
                   "(GPU) run under autocast, channels-last (docs/denoise.md 'Speed')")
    p.add_argument("--reference", type=Path,
                   help="folder of references, one EXR per frame named as the frame, to score input and "
                   "output against (input a; default: the frames' folder's reference/ when it has one for "
                   "every frame; docs/denoise.md 'Scores of frames')")
    p.add_argument("--max-memory-mb", type=arguments.float_in(0, 2**24, lo_open=True), default=4096,
                   help="memory cap of one network pass; larger frames go in overlapping tiles (input a)")
    p.add_argument("--overlap", type=arguments.int_in(0, 1024), default=32,
                   help="tile overlap in pixels (input a)")
    p.add_argument("--allow-large", action="store_true",
                   help="run work above the limits of docs/denoise.md 'Limits' (samples of a scene, pixels "
                   "of frames)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p


def pick_device(name: str) -> torch.device:
    import torch

    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    device = torch.device(name)
    if device.type == "cuda" and not torch.cuda.is_available():
        raise ValueError(f"--device={name}: torch sees no CUDA device here; use --device cpu")
    return device


def load_model(args: argparse.Namespace) -> weights.Loaded:
    """The checkpoint's model, or (no ``--checkpoint``) an experiment without weights."""
    from mcd.denoise.configs import check_experiment

    if args.experiment is not None:
        check_experiment(args.experiment)
    if args.checkpoint:
        return weights.load(args.checkpoint, args.experiment, args.capacity)
    if not args.experiment:
        raise ValueError("give --checkpoint (a run directory, a .ckpt file or a bundled name: "
                         f"{', '.join(weights.bundled_names()) or 'none installed'}), or --experiment of a "
                         "method without weights (oidn, noisy)")
    from mcd.config.compose import compose
    from mcd.models import build

    capacity = [f"capacity={args.capacity}"] if args.capacity else []
    cfg = compose([f"+experiment={args.experiment}", *capacity])
    if bool(cfg.method.get("trainable", True)):
        raise ValueError(f"--experiment={args.experiment} has weights to train: give its --checkpoint")
    return weights.Loaded(build(cfg).eval(), cfg, f"experiment {args.experiment} (no weights)")


def run(argv: list[str] | None = None) -> dict:
    """Parse ``argv``, denoise, write ``<output>/denoise.json``; returns its content. A refused input exits 2
    with the message on stderr. The output folder and every input are checked before any work
    (docs/reliability.md, "Denoising your frames")."""
    args = parser().parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    allocator.keep_freed_memory()           # full frames reuse freed pages (mcd/core/allocator.py)
    # -o is locked from its check to the last write of denoise.json (output_folder.hold, in _scene/_frames)
    with contextlib.ExitStack() as folder_lock:
        return _run(args, folder_lock)


def _run(args: argparse.Namespace, folder_lock: contextlib.ExitStack) -> dict:
    """:func:`run` with the parsed ``args``; ``folder_lock`` holds the lock of ``-o`` once it is taken."""
    try:
        device = pick_device(args.device)
        dtype = precision.check(args.precision, device)
        loaded = load_model(args)
        log.info("model: %s, experiment %s, budget %s", loaded.source, loaded.experiment, loaded.cfg.budget)
        meta = {"checkpoint": loaded.source, "experiment": loaded.experiment, "provenance": loaded.provenance,
                "precision": args.precision, "device": str(device), "allocator": allocator.policy()}
        if args.scene is not None:
            report = _scene(args, loaded, device, dtype, folder_lock)
        else:
            report = _frames(args, loaded, device, dtype, meta, folder_lock)
    except (ValueError, FileNotFoundError, RuntimeError, ImportError) as err:  # ImportError: a missing extra
        print(f"mcd-denoise: error: {err}", file=sys.stderr)
        raise SystemExit(2) from err
    except OSError as err:
        if err.errno not in (errno.ENOSPC, errno.EDQUOT):
            raise
        # a disk that filled during the work: each output is written whole or not at all (atomic), and
        # denoise.json lists the frames finished with their checksums, so the same command resumes
        print(f"mcd-denoise: error: {err.filename or args.output}: {err.strerror}; the frames finished "
              f"before are kept in -o {args.output} (denoise.json); free space there (or give another -o) "
              "and run the same command again: it resumes", file=sys.stderr)
        raise SystemExit(1) from err
    report.update(meta)
    record = report.pop("record", None)
    if record is not None:
        record.write(report, complete=True)
    else:
        write_json(args.output / SUMMARY, report)
    return report


def _scene(args: argparse.Namespace, loaded: weights.Loaded, device: torch.device,
           dtype: torch.dtype | None, folder_lock: contextlib.ExitStack) -> dict:
    """Input (b): check ``-o``, render and denoise the scene, print each frame's samples and scores."""
    if args.inputs:
        raise ValueError("give either EXR frames or --scene, not both")
    from mcd.data.buffers import uniform_buffer
    from mcd.data.scenes import SceneSpec, path_scene_name
    from mcd.denoise.scene import denoise_scene, report_lines

    name = path_scene_name(args.scene)
    cfg = loaded.cfg
    budget = int(cfg.budget)
    extra = loaded.adaptive and uniform_buffer(budget) in set(loaded.model.required_buffers())
    levels = int((cfg.method.get("sampling", None) or {}).get("levels", 5))

    def check_work(width: int, height: int) -> None:
        samples = work.scene_samples(width, height, args.frames, budget, args.gbuffer_spp, args.reference_spp,
                                     loaded.adaptive, levels, extra)
        work.check(samples, work.MAX_SAMPLES, f"--scene {args.scene} at {width}x{height}, {args.frames} "
                   f"frame(s), budget {budget}, --gbuffer-spp {args.gbuffer_spp}, --reference-spp "
                   f"{args.reference_spp}: samples to trace", args.allow_large)

    if args.width is not None and args.height is not None:
        check_work(args.width, args.height)          # before the scene is loaded, where the size is given
    # a missing or unreadable scene file is named before -o is claimed (its first denoise.json was left)
    SceneSpec(name, "xml", file=Path(args.scene).resolve(),
              missing_hint="check the path given to --scene").check_readable()
    outputs = [n for f in range(args.frames) for n in frame_files(f"{name}_{f:04d}")]
    output_folder.check_apart(args.output, [args.scene], [SUMMARY, *outputs])
    output_folder.check_unrecorded(args.output, SUMMARY, outputs)
    if (args.output / SUMMARY).exists():  # another program's (or a damaged) denoise.json: never replaced
        from mcd.denoise.resume import check_earlier_outputs, check_kind

        check_kind(args.output / SUMMARY, scene=True)   # read_record's checks, then the earlier run's kind
        check_earlier_outputs(args.output / SUMMARY, outputs)
    output_folder.check_writable(args.output)
    folder_lock.enter_context(output_folder.hold(args.output))
    output_folder.claim(args.output, SUMMARY)
    report = denoise_scene(loaded, args.scene, args.output, device, args.width, args.height,
                           args.frames, args.gbuffer_spp, args.seed, args.reference_spp,
                           progress=not args.no_progress, dtype=dtype, exposure=args.exposure,
                           reference_db=args.reference_db or None, reference_max_spp=args.reference_max_spp,
                           check_work=check_work)
    print("\n".join(report_lines(report)))
    return report


def _frames(args: argparse.Namespace, loaded: weights.Loaded, device: torch.device, dtype: torch.dtype | None,
            meta: dict, folder_lock: contextlib.ExitStack) -> dict:
    """Input (a): find and check the frames and ``-o`` (before any work), denoise (resuming), print."""
    if not args.inputs:
        raise ValueError("give EXR frames (a folder, files or a glob pattern) or --scene <scene.xml>")
    from mcd.denoise.frame_scores import check_references, find_references, score_text
    from mcd.denoise.frames import check_frames, find_frames, read_header, refuse_clamping_exposure, siblings
    from mcd.denoise.resume import (
        Record,
        check_earlier_outputs,
        check_kind,
        config_digest,
        file_stamps,
        weights_digest,
    )
    from mcd.denoise.sequence import denoise_frames, exposure_target, wanted_layers

    paths = find_frames(args.inputs)
    refs = find_references(paths, args.reference)
    inputs = [f for p in paths for f in (p, *siblings(p))]     # what the outputs depend on
    outputs = [n for p in paths for n in frame_files(p.stem)]
    output_folder.check_apart(args.output, inputs + (refs or []), [SUMMARY, *outputs])
    output_folder.check_unrecorded(args.output, SUMMARY, outputs)
    (h, w), _ = read_header(paths[0])
    work.check(h * w * len(paths), work.MAX_PIXELS, f"{len(paths)} frames of {w}x{h}: pixels to denoise",
               args.allow_large)
    output_folder.check_writable(args.output)
    main_files = [n for p in paths for n in frame_files(p.stem)[:2]]  # every method writes these two
    output_folder.check_space(args.output, [n for n in main_files if not (args.output / n).is_file()], h * w)
    folder_lock.enter_context(output_folder.hold(args.output))
    scan = check_frames(paths, wanted_layers(loaded), exposure_target(loaded))  # the one read before the work
    if args.exposure is not None:  # before -o is claimed
        refuse_clamping_exposure(args.exposure, scan.exposures, paths[0].parent, exposure_target(loaded))
    if refs:
        check_references(refs, scan.size)
    settings = {"inputs": file_stamps(inputs), "weights_sha256": weights_digest(loaded.model),
                "config_sha256": config_digest(loaded.cfg),
                "experiment": loaded.experiment, "budget": loaded.cfg.budget, "precision": args.precision,
                "device": str(device), "max_memory_mb": args.max_memory_mb, "overlap": args.overlap,
                "exposure": args.exposure}
    check_kind(args.output / SUMMARY, scene=False)
    check_earlier_outputs(args.output / SUMMARY, outputs)
    record = Record(args.output, settings)  # reads a previous run's record, before claim writes a first one
    output_folder.claim(args.output, SUMMARY)
    report = denoise_frames(loaded, paths, args.output, device, args.max_memory_mb, args.overlap,
                            progress=not args.no_progress, dtype=dtype, record=record, meta=meta,
                            references=refs, exposure=args.exposure, scan=scan)
    for what in ("input", "reference"):  # a reference's counts are keyed <file>:reference
        counts = {k: v for k, v in report["sanitised"].items()
                  if k.endswith(":reference") == (what == "reference")}
        if counts:
            print(f"sanitised: {sum(counts.values())} NaN/Inf/negative {what} values replaced by 0 "
                  f"({', '.join(f'{k} {v}' for k, v in counts.items())})")
    if "scores" in report:
        for row in report["scores"]["frames"]:
            print(f"frame {row['frame']}: {score_text(row)}")
        print(f"mean of {len(report['scores']['frames'])} frame(s): {score_text(report['scores']['mean'])} "
              f"(against {refs[0].parent}; exposure x{report['exposure']:.4g} for all)")
    resumed = f" ({len(report['resumed'])} finished before, kept)" if report["resumed"] else ""
    print(f"{report['frames']} frames denoised in {report['tiles']} tile(s) each{resumed} -> {args.output}")
    return {**report, "record": record}


def main(argv: list[str] | None = None) -> int:
    """The console script ``mcd-denoise`` (exit status 0; 2 for a refused input)."""
    run(argv)
    return 0

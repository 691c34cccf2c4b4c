"""Where a two-stage run's error lies, stage by stage, on the frame's outer ring and inside it
(notes/dark_regions.md "Where F loses cbox's FLIP").

For a finished run of a row with the kernel pool (its ``resolved_config.yaml`` and the checkpoint it tested,
from its ``metrics.json``), every test frame of one scene is denoised again, in sequence, keeping each stage:
the noisy render ``c_s``, the kernel pool's ``i_bar``, ``F_d``'s raw output (before the output steps) and that
output after the frame-mean match (:func:`mcd.models.mean_match.match_frame_mean` against the adaptive image,
as ``method.mean_match`` applies it in test). ``method.pass_misses`` is left out, so a frame with a black
frame of escaped rays shows what the network put there. Per stage, over the frames: the mean bias in display
values (:func:`mcd.core.metrics.to_display` of the stage minus the reference's) on the outer
``--width``-pixel ring and inside it, and FLIP on each; per frame, the matched output's bias on each side of
the ring. ``--all-frames`` denoises the scene's whole sequence as one test sequence (training frames
included), which
tells a bias of the held-out frames from one the training frames share::

    python tools/stage_ring.py RUN_DIR [--scene cbox] [--width 3] [--all-frames]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

STAGES = ("noisy", "i_bar", "raw F_d", "matched")
SIDES = ("top", "bottom", "left", "right")


def ring_mask(h: int, w: int, width: int) -> np.ndarray:
    """``H x W`` booleans, true on the outer ``width`` pixels of the frame."""
    if not 0 < 2 * width < min(h, w):
        raise ValueError(f"--width {width}: the ring must leave an interior in a {h}x{w} frame")
    inner = np.zeros((h, w), bool)
    inner[width:-width, width:-width] = True
    return ~inner


def ring_stats(image: np.ndarray, ref: np.ndarray, width: int) -> dict[str, float]:
    """Display-value bias and FLIP of ``image`` against ``ref`` (``H x W x 3``, linear) on the ring and inside
    it, and the bias on each side of the ring (corners left out)."""
    from mcd.core.metrics import flip_map, to_display

    diff = to_display(image) - to_display(ref)
    err = flip_map(image, ref)
    ring = ring_mask(*diff.shape[:2], width)
    w = width
    sides = (diff[:w, w:-w], diff[-w:, w:-w], diff[w:-w, :w], diff[w:-w, -w:])
    return {"ring_bias": float(diff[ring].mean()), "inner_bias": float(diff[~ring].mean()),
            "ring_flip": float(err[ring].mean()), "inner_flip": float(err[~ring].mean()),
            "flip": float(err.mean()), **{s: float(v.mean()) for s, v in zip(SIDES, sides, strict=True)}}


Frames = dict[int, dict[str, dict[str, float]]]  # frame -> stage -> ring_stats


def measure(run_dir: Path, scene: str, width: int, all_frames: bool) -> Frames:
    """Per frame and stage, :func:`ring_stats` of ``scene``'s frames as the run's tested weights denoise them
    (module docstring), stepped by :meth:`mcd.lit.module.DenoiseModule.test_step` under the run's precision
    (bf16 autocast for a run tested in ``bf16-mixed``, as :func:`tools.edge_effect.measure` does: the
    sampling map rounds from the logits, so the precision changes the samples drawn)."""
    import torch
    from omegaconf import OmegaConf, open_dict

    from mcd.data import MCDDataModule, StoreBuilder
    from mcd.data.buffers import run_buffers
    from mcd.lit import checkpoint
    from mcd.lit.module import DenoiseModule
    from mcd.lit.test_recorder import hwc
    from mcd.models import build
    from mcd.models.mean_match import match_frame_mean

    metrics = json.loads((run_dir / "metrics.json").read_text())
    cfg = OmegaConf.load(run_dir / "resolved_config.yaml")
    with open_dict(cfg):
        cfg.method.mean_match, cfg.method.pass_misses = False, False  # the raw F_d output; matched below
        cfg.data.test_scenes = [scene]
        if all_frames:  # one test sequence of every frame: no validation or training split left
            cfg.data.test_fraction, cfg.data.val_clips, cfg.data.clip_len = 0.97, 0, 1
    model = build(cfg)
    if not getattr(model, "sw", {}).get("KP"):
        raise ValueError(f"{run_dir}: method {cfg.method.name} has no kernel pool (no i_bar to measure)")
    weights = checkpoint.model_weights(checkpoint.safe_load(metrics["checkpoint"], "checkpoint"))
    checkpoint.check_fits(model, weights, "checkpoint", metrics["checkpoint"])
    model.load_state_dict(weights)
    store = StoreBuilder.from_cfg(cfg, overrides=[])
    data = MCDDataModule(cfg, store, run_buffers(model.required_buffers(), cfg.budget), model.window)
    module = DenoiseModule(cfg, model, None).eval()
    bf16 = str(metrics.get("precision", "32-true")).startswith("bf16")
    out: Frames = {}
    with torch.inference_mode(), torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
        for i, batch in enumerate(data.test_dataloader()):
            step = module.test_step(batch, i)
            y, ref = step["outputs"], hwc(step["ref"])
            stages = (step["noisy"], y["initial"][0], y["output"][0],
                      match_frame_mean(y["output"], y["adaptive"])[0])
            out[step["frame"]] = {name: ring_stats(hwc(s), ref, width)
                                  for name, s in zip(STAGES, stages, strict=True)}
    return out


def report(frames: Frames, width: int) -> str:
    """The two Markdown tables of the module docstring."""
    keys = ("ring_bias", "inner_bias", "ring_flip", "inner_flip", "flip")
    lines = [f"| stage | bias, {width}-px ring | bias, inside | FLIP, ring | FLIP, inside | FLIP |",
             "|---|---|---|---|---|---|"]
    for stage in STAGES:
        means = [np.mean([f[stage][k] for f in frames.values()]) for k in keys]
        lines.append(f"| {stage} | " + " | ".join(f"{v:+.4f}" if i < 2 else f"{v:.4f}"
                                                  for i, v in enumerate(means)) + " |")
    lines += ["", "| frame | matched: " + " | ".join(SIDES) + " | inside |", "|---|---|---|---|---|---|"]
    for n, f in sorted(frames.items()):
        m = f["matched"]
        lines.append(f"| {n} | " + " | ".join(f"{m[k]:+.3f}" for k in (*SIDES, "inner_bias")) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python tools/stage_ring.py", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("run_dir", type=Path, help="a finished run directory (metrics.json, resolved config)")
    parser.add_argument("--scene", default="cbox")
    parser.add_argument("--width", type=int, default=3, help="the ring's width in pixels")
    parser.add_argument("--all-frames", action="store_true", help="the whole sequence, training frames too")
    args = parser.parse_args(argv)
    if not (args.run_dir / "metrics.json").is_file():
        parser.error(f"{args.run_dir}: no metrics.json (a finished run directory of python -m mcd.run)")
    frames = measure(args.run_dir, args.scene, args.width, args.all_frames)
    print(f"python tools/stage_ring.py {args.run_dir} --scene {args.scene} --width {args.width}"
          f"{' --all-frames' if args.all_frames else ''}: {len(frames)} frames, means over them\n")
    print(report(frames, args.width))


if __name__ == "__main__":
    main()

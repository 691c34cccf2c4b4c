"""``python tools/bundle_scores.py``: the bundled checkpoints scored on held-out scenes beside OIDN and
the noisy input (docs/denoise.md, "Bundled checkpoints").

For each transfer scene of the data profile (``--data``, default ``bundle``: ``data.transfer_scenes``, the
scenes the bundles never trained on), each method runs on the scene's whole test sequence from the store as
``mcd.run``'s test does (``reset()`` at the sequence start, the frame window of the model; the adaptive
methods build their simulated adaptive render from the stored ``c_1 .. c_32``), and each output frame is
scored against the reference by :func:`mcd.core.metrics.frame_metrics`: PSNR, SSIM, rMSE and FLIP, averaged
over the frames of a scene. The methods: the given bundles (``--bundle``, repeated: names of ``mcd/bundled``,
bundle ``.pt`` files or run directories; default every bundled checkpoint), OIDN (``+experiment=oidn``, when
its package is installed) and the noisy uniform render at the budget. What the store lacks of the scenes' test
frames is rendered first (only those frames: a transfer scene is never trained on).

Prints a Markdown table with the command, commit, machine and load average above it; ``--write FILE`` also
replaces the text between ``<!-- bundle-scores -->`` and ``<!-- /bundle-scores -->`` in ``FILE`` with it, so
that the documented table is the command's output.
"""

from __future__ import annotations

import argparse
import logging
import os
import shlex
import sys
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import DictConfig
from torch import nn

from mcd.config.methods import display_name
from mcd.core.metrics import frame_metrics
from mcd.core.paths import CONF_DIR
from mcd.data.buffers import run_buffers, uniform_buffer
from mcd.data.clips import ExrClips
from mcd.data.shards import Selection
from mcd.data.splits import test_frame_count
from mcd.lit.test_recorder import hwc
from tools._doc_section import check, write_section

log = logging.getLogger(__name__)

#: The scores of the table, in its column order.
SCORES = ("psnr", "ssim", "rmse", "flip")
#: The references scored beside the bundles (never trained on a scene).
REFERENCES = (display_name("oidn"), display_name("noisy"))
SECTION = "bundle-scores"  # docs/denoise.md holds the table between <!-- bundle-scores --> lines


def _methods(bundles: list[str], data_overrides: list[str]) -> list[tuple[str, nn.Module | None, DictConfig]]:
    """``(label, model, cfg)`` of each bundle, then OIDN if installed, then the noisy input (model None)."""
    from mcd.config.compose import compose
    from mcd.denoise import weights
    from mcd.models import build

    out: list[tuple[str, nn.Module | None, DictConfig]] = []
    for spec in bundles:
        loaded = weights.load(spec)
        out.append((Path(spec).stem if spec.endswith(".pt") else spec, loaded.model, loaded.cfg))
    oidn_cfg = compose(["+experiment=oidn", *data_overrides])
    try:
        oidn = build(oidn_cfg).eval()
    except ImportError as e:
        log.warning("%s left out: %s", display_name("oidn"), e)
    else:
        out.append((display_name("oidn"), oidn, oidn_cfg))
    out.append((display_name("noisy"), None, oidn_cfg))
    return out


def trained_on(cfg: DictConfig) -> list[str]:
    """The scenes a bundle's model trained on: its recorded ``data.train_scenes``, or for a bundle written
    before they were recorded, those of the data profile it names (``data.name``, when it is one of
    ``conf/data``); empty when neither is known."""
    from mcd.config.compose import compose

    recorded = cfg.data.get("train_scenes")
    if recorded is not None:
        return list(recorded)
    name = str(cfg.data.get("name"))
    if not (CONF_DIR / "data" / f"{name}.yaml").is_file():
        return []
    return list(compose([f"data={name}"]).data.train_scenes)


@torch.inference_mode()
def score(store: Any, scene: str, frames: list[int], model: nn.Module | None,
          budget: float) -> dict[str, float]:
    """The mean of :data:`SCORES` over ``frames`` (a test sequence of ``scene``) of ``model``'s outputs, or of
    the uniform render at ``budget`` when ``model`` is None."""
    from mcd.data.datamodule import SequenceDataset

    bufs = sorted(run_buffers(_required(model), budget))
    window = tuple(getattr(model, "window", (0, 0))) if model is not None else (0, 0)
    seq = SequenceDataset(ExrClips(store, bufs, cache=False), [(scene, frames)], window)  # type: ignore[arg-type]
    rows = []
    for i in range(len(seq)):
        item = seq[i]
        images = {k: v[None] for k, v in item.items() if isinstance(v, torch.Tensor) and v.ndim == 4}
        past = window[0]  # the current frame's index in the window
        ref = images["ref"][0, past]
        if model is None:
            out = images[uniform_buffer(budget)][0, past]
        else:
            if bool(item["reset"]):
                model.reset()
            x = {k: v[:, past] if window == (0, 0) else v for k, v in images.items()}
            x["ref"] = None
            out = model(x)["output"][0].float()
        m = frame_metrics(hwc(out), hwc(ref))
        rows.append([m[k] for k in SCORES])
    return dict(zip(SCORES, np.mean(np.asarray(rows, dtype=np.float64), axis=0).tolist(), strict=True))


def _required(model: nn.Module | None) -> set[str]:
    """The buffers ``model`` reads (none for the noisy input)."""
    return set(model.required_buffers()) if model is not None else set()


def table(bundles: list[str], data_overrides: list[str]) -> tuple[str, DictConfig, list[str]]:
    """The Markdown table (module docstring), rendering what the store lacks first; with the composed
    config and the scenes. A method marked ``(trained on it)`` had the scene among its training scenes."""
    from mcd.config.compose import compose
    from mcd.data import StoreBuilder

    cfg = compose(data_overrides)
    scenes = list(cfg.data.get("transfer_scenes") or [])
    if not scenes:
        raise SystemExit(f"data profile {cfg.data.name}: data.transfer_scenes is empty; the bundles are "
                         "scored on held-out scenes (use --data bundle, or name them with "
                         "'data.transfer_scenes=[..]')")
    methods = _methods(bundles, data_overrides)
    trained = {label: trained_on(mcfg) if label not in REFERENCES else [] for label, _, mcfg in methods}
    budget = float(cfg.budget)
    store = StoreBuilder.from_cfg(cfg)
    need: set[str] = set()
    for _, model, _ in methods:
        need |= _required(model)
    d = cfg.data
    n_test = test_frame_count(store.n_frames, float(d.test_fraction))
    store.ensure(run_buffers(need, budget), scenes=scenes, selection=Selection(frames=(0, n_test)))
    header = "| scene | method | PSNR (dB) | SSIM | rMSE | FLIP |\n|---|---|---|---|---|---|\n"
    lines, means = [], {label: [] for label, _, _ in methods}
    for scene in scenes:
        frames = list(range(n_test))
        for label, model, _ in methods:
            s = score(store, scene, frames, model, budget)
            means[label].append(s)
            seen = label not in REFERENCES and scene in trained[label]
            lines.append(f"| {scene} | {label}{' (trained on it)' if seen else ''} | {_cells(s)} |")
            log.info("%s %s: %s", scene, label, s)
    for label, rows in means.items():
        m = {k: float(np.mean([r[k] for r in rows])) for k in SCORES}
        lines.append(f"| **mean** | {label} | {_cells(m)} |")
    return header + "\n".join(lines) + "\n", cfg, scenes


def _cells(s: dict[str, float]) -> str:
    """PSNR, SSIM, rMSE, FLIP as table cells."""
    return f"{s['psnr']:.2f} | {s['ssim']:.4f} | {s['rmse']:.4f} | {s['flip']:.4f}"


def provenance(argv: list[str], cfg: DictConfig, scenes: list[str], load: tuple[float, float]) -> str:
    """What the table came from: command, commit, machine, load, data."""
    from mcd.core.machine import device_name
    from mcd.core.provenance import short_commit

    d = cfg.data
    command = " ".join(["python tools/bundle_scores.py", *map(shlex.quote, argv)])
    q = d.ref_quality
    return (f"`{command}` at commit {short_commit()}, {device_name(torch.device('cpu'))}, load average "
            f"{load[0]:.1f} at the start and {load[1]:.1f} at the end (the whole machine's, other processes "
            f"included). Data profile `{d.name}` ({d.width}x{d.height}, budget {cfg.budget} spp), "
            f"transfer scenes {', '.join(scenes)}: each scene's test frames, references to {q.target_db} dB "
            f"at most {q.max_spp} spp.\n\n")


def main(argv: list[str] | None = None) -> None:
    argv = list(sys.argv[1:] if argv is None else argv)
    p = argparse.ArgumentParser(prog="python tools/bundle_scores.py",
                                description=__doc__.split("\n\n")[0])
    p.add_argument("--bundle", action="append", dest="bundles",
                   help="a bundle name, .pt file or run dir; repeat for more (default: every bundled one)")
    p.add_argument("--data", default="bundle", help="the data profile whose transfer scenes are scored")
    p.add_argument("--write", type=Path, help="also write the table into this file between the markers")
    p.add_argument("overrides", nargs="*",
                   help="further Hydra overrides of the data (e.g. paths.data_dir=..)")
    args = p.parse_args(argv)
    if args.write is not None:
        check(args.write, SECTION)  # before any rendering or scoring
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(name)s %(message)s")
    from mcd.denoise.weights import bundled_names

    bundles = args.bundles or bundled_names()
    load0 = os.getloadavg()[0]
    body, cfg, scenes = table(bundles, [f"data={args.data}", *args.overrides])
    text = provenance(argv, cfg, scenes, (load0, os.getloadavg()[0])) + body
    print(text)
    if args.write is not None:
        write_section(args.write, text, SECTION)


if __name__ == "__main__":
    main()

"""What ``method.output_bound`` changes on the bundled checkpoints' outputs (docs/method.md "Output").

For each bundle and each scene's test frames of a store (the ``bundle`` profile, any size), the model runs
twice, with the bound and without it (the same weights), as ``tools/bundle_scores.py`` runs it.
Prints per bundle and scene: the share of output values the bound changed (any change above 1e-6 relative),
the largest change, and rMSE / PSNR without and with it. Usage (MCD_SCENES_DIR set):

    OMP_NUM_THREADS=1 PYTHONPATH=. python tools/output_bound_effect.py 'data.transfer_scenes=[..]' \\
        data.width=64 ...
"""

from __future__ import annotations

import sys

import numpy as np
import torch
from omegaconf import open_dict

from mcd.config.compose import compose
from mcd.core.metrics import psnr, rmse
from mcd.data import StoreBuilder
from mcd.data.buffers import run_buffers
from mcd.data.clips import ExrClips
from mcd.data.datamodule import SequenceDataset
from mcd.data.shards import Selection
from mcd.data.splits import test_frame_count
from mcd.denoise import weights
from mcd.lit.test_recorder import hwc
from mcd.models import build


def bundles() -> list[tuple[str, torch.nn.Module, torch.nn.Module]]:
    out = []
    for name in weights.bundled_names():
        loaded = weights.load(name)
        cfg = loaded.cfg.copy()
        with open_dict(cfg):
            cfg.method.output_bound = False
        free = build(cfg)
        free.load_state_dict(loaded.model.state_dict())
        out.append((name, loaded.model.eval(), free.eval()))
    return out


@torch.inference_mode()
def main(overrides: list[str]) -> None:
    cfg = compose(["data=bundle", *overrides])
    scenes = list(cfg.data.transfer_scenes) + list(cfg.data.test_scenes)
    models = bundles()
    budget = float(cfg.budget)
    store = StoreBuilder.from_cfg(cfg)
    need = set().union(*(set(m.required_buffers()) for _, m, _ in models))
    n_test = test_frame_count(store.n_frames, float(cfg.data.test_fraction))
    store.ensure(run_buffers(need, budget), scenes=scenes, selection=Selection(frames=(0, n_test)))
    print("| bundle | scene | values changed | largest change | rMSE without / with | PSNR without / with |")
    print("|---|---|---|---|---|---|")
    for name, bounded, free in models:
        bufs = sorted(run_buffers(set(bounded.required_buffers()), budget))
        for scene in scenes:
            seq = SequenceDataset(ExrClips(store, bufs, cache=False), [(scene, list(range(n_test)))], (0, 0))
            changed = total = 0
            largest, rows = 0.0, []
            for i in range(len(seq)):
                item = seq[i]
                x = {k: v[None, 0] for k, v in item.items() if isinstance(v, torch.Tensor) and v.ndim == 4}
                ref = hwc(x.pop("ref")[0])
                x["ref"] = None
                if bool(item["reset"]):
                    bounded.reset()
                    free.reset()
                torch.manual_seed(i)
                a = bounded(dict(x))["output"][0].float()
                torch.manual_seed(i)
                b = free(dict(x))["output"][0].float()
                diff = (a - b).abs()
                changed += int((diff > 1e-6 * (b.abs() + 1e-6)).sum())
                total += diff.numel()
                largest = max(largest, float(diff.max()))
                rows.append([rmse(hwc(b), ref), rmse(hwc(a), ref), psnr(hwc(b), ref), psnr(hwc(a), ref)])
            r = np.mean(rows, axis=0)
            print(f"| {name} | {scene} | {changed}/{total} ({changed / total:.2e}) | {largest:.3g} | "
                  f"{r[0]:.4g} / {r[1]:.4g} | {r[2]:.2f} / {r[3]:.2f} |", flush=True)


if __name__ == "__main__":
    main(sys.argv[1:])

"""Where a trained model's colour shifts and border artefacts come from (docs/method.md "Output"; issue 12).
Not a test: prints figures.

    python benchmarks/output_artefacts.py CHECKPOINT [overrides ...]

CHECKPOINT is what ``mcd-denoise --checkpoint`` takes (a run directory, a ``.ckpt``, a bundled name), or
``oidn`` / ``noisy`` (methods without weights). The model
is tested on the test frames of the configured data profile (default ``data=small model=cpu``; the overrides
are Hydra's, e.g. ``data=tiny``), in fp32, as ``python -m mcd.run`` tests. Per scene, averaged over its test
frames, for each stage the model returns (the adaptive render ``i``, the initial denoise ``i_bar``, the
output) and for the noisy uniform input: PSNR (dB), border gap (dB: PSNR of the outer 4-pixel frame minus the
interior's) and colour shift (largest per-channel relative difference of the frame mean from the
reference's), the metrics of ``mcd.metrics`` (docs/benchmark.md "Metrics").
"""

from __future__ import annotations

import shlex
import sys

import lightning as L
import numpy as np

from mcd.data import Store
from mcd.data.buffers import run_buffers
from mcd.data.datamodule import MCDDataModule
from mcd.denoise.configs import compose
from mcd.denoise.weights import load
from mcd.lit.module import DenoiseModule
from mcd.lit.test_recorder import hwc
from mcd.metrics import border_gap, colour_shift, psnr
from mcd.models import build

STAGES = ("adaptive", "initial", "output")
WITHOUT_WEIGHTS = ("oidn", "noisy")


class _Collect(L.Callback):
    def __init__(self) -> None:
        self.rows: dict[str, list[dict[str, tuple[float, float, float]]]] = {}

    def on_test_batch_end(self, trainer, pl_module, outputs, batch, batch_idx, dataloader_idx=0) -> None:
        out, ref = outputs["outputs"], hwc(outputs["ref"])
        images = {k: hwc(out[k][0]) for k in STAGES if k in out}
        images["noisy input"] = hwc(outputs["noisy"])
        self.rows.setdefault(outputs["scene"], []).append(
            {k: (psnr(x, ref), border_gap(x, ref), colour_shift(x, ref)) for k, x in images.items()})


def main(argv: list[str]) -> None:
    if not argv or argv[0] in ("-h", "--help"):
        print(__doc__)
        return
    if argv[0] in WITHOUT_WEIGHTS:
        cfg = compose(f"+experiment={argv[0]}", "data=small", "model=cpu", *argv[1:])
        model, source = build(cfg).eval(), f"{argv[0]} (no weights)"
    else:
        loaded = load(argv[0])
        cfg = compose(f"+experiment={loaded.experiment}", "data=small", "model=cpu", *argv[1:])
        model, source = loaded.model, loaded.source
    store = Store.from_cfg(cfg)
    buffers = run_buffers(model.required_buffers(), cfg.budget)
    store.ensure(buffers, progress=False)
    collect = _Collect()
    trainer = L.Trainer(accelerator="cpu", logger=False, enable_progress_bar=False, callbacks=[collect],
                        precision="32-true", enable_model_summary=False)
    trainer.test(DenoiseModule(cfg, model, None), datamodule=MCDDataModule(cfg, store, buffers, model.window),
                 verbose=False)
    print(f"# python benchmarks/output_artefacts.py {shlex.join(argv)}")
    print(f"# {source}; data={cfg.data.name}; PSNR dB / border gap dB / colour shift %, test frames")
    for scene, rows in collect.rows.items():
        cells = []
        for stage in rows[0]:
            p, g, c = (float(np.nanmean([r[stage][i] for r in rows])) for i in range(3))
            cells.append(f"{stage} {p:.2f} / {g:+.2f} / {100 * c:.1f}")
        print(f"{scene:20s} " + " | ".join(cells))


if __name__ == "__main__":
    main(sys.argv[1:])

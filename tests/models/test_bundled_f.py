"""The bundled F (``mcd/bundled/F-cpu-small``, trained on ``data=small``) on frames rendered here, of the
three vendored training scenes at 96x96 (issue 12's two checks on the output, docs/benchmark.md "Metrics"):

- no colour cast: each channel's frame mean within 5% of the reference's (``mcd.metrics.colour_shift``), per
  frame;
- no border artefact: the edge effect (``mcd.edge_effect``: the outer 4-pixel frame of a 64x64 inset crop as
  the crop's border against the same pixels inside the whole frame) at least -1 dB per scene, averaged over
  its test frames.

It also beats its noisy input on every frame. The literal "outer frame within 1 dB of the interior" is not
asked: content decides it (docs/benchmark.md, "Border gap").
"""

from __future__ import annotations

import numpy as np
import pytest

from mcd.data import Store
from mcd.data.buffers import run_buffers
from mcd.data.datamodule import MCDDataModule
from mcd.denoise.configs import compose
from mcd.denoise.weights import load
from mcd.edge_effect import measure
from mcd.lit.module import DenoiseModule

SCENES = ("cbox", "cornell-box-picture", "staircase2")


@pytest.fixture(scope="module")
def rows(tmp_path_factory) -> list[dict[str, object]]:
    """``mcd.edge_effect.measure`` of the bundled F on the test frames (2 per scene) of a 96x96 store."""
    loaded = load("F-cpu-small")
    cfg = compose(
        "+experiment=F", "model=cpu", "data=tiny", "data.name=bundled_f",
        f"paths.data_dir={tmp_path_factory.mktemp('data')}",
        "data.width=96", "data.height=96", "data.segments=1", "data.frames_per_segment=4",
        "data.test_fraction=0.5", "data.val_clips=0", "data.clip_len=2",  # render 2 test frames, 2 others
        "data.ref_spp=512", "data.ref_quality.target_db=null",
        "+scene@data.scenes.cornell-box-picture=cornell-box-picture",
        f"data.train_scenes=[{','.join(SCENES)}]", f"data.test_scenes=[{','.join(SCENES)}]",
    )
    store = Store.from_cfg(cfg, overrides=[])
    buffers = run_buffers(loaded.model.required_buffers(), cfg.budget)
    store.ensure(buffers, progress=False)
    datamodule = MCDDataModule(cfg, store, buffers, loaded.model.window)
    datamodule.setup("test")
    return measure(DenoiseModule(cfg, loaded.model, None), datamodule.test_dataloader())


def test_bundled_f_beats_its_input_without_a_colour_cast(rows):
    assert sorted({r["scene"] for r in rows}) == sorted(SCENES)
    for r in rows:
        assert r["psnr"] > r["input_psnr"], r
        assert r["colour_shift"] < 0.05, r


def test_bundled_f_has_no_border_artefact(rows):
    for scene in SCENES:
        effect = float(np.mean([r["edge_effect"] for r in rows if r["scene"] == scene]))
        assert effect >= -1.0, (scene, [r for r in rows if r["scene"] == scene])

"""The bundled F (``mcd/bundled/F-cpu-small``, trained on ``data=small``) on frames rendered here, of the
three vendored training scenes at 96x96 (two checks on the output, docs/benchmark.md "Metrics"):

- no colour cast: each channel's frame mean within 5% of the reference's (``mcd.core.metrics.colour_shift``),
  per frame; and it beats its noisy input on every frame;
- no border artefact: the edge effect (``tools.edge_effect``: the outer 4-pixel frame of a 64x64 inset
  crop as the crop's border, against the same pixels inside the whole frame) at least -1 dB averaged over the
  scenes, and on each scene no worse than OIDN's on the same frames (when ``pyoidn`` is installed, as
  ``scripts/setup.sh`` does). Per scene the image border costs every method something where a sharp edge
  meets it (cornell-box-picture: F -1.4 dB, OIDN -3.7 dB when this test was written), so the 1 dB bound is
  asked of the average, and OIDN is the bound per scene.

The literal "outer frame within 1 dB of the interior" is not asked: content decides it (docs/benchmark.md,
"Border gap").
"""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest

from mcd.config.compose import compose
from mcd.data import StoreBuilder, splits
from mcd.data.buffers import run_buffers
from mcd.data.datamodule import MCDDataModule
from mcd.data.shards import Selection
from mcd.denoise.weights import load
from mcd.lit.module import DenoiseModule
from mcd.models import build
from tools.edge_effect import measure

SCENES = ("cbox", "cornell-box-picture", "staircase2")
HAS_PYOIDN = importlib.util.find_spec("pyoidn") is not None


def _rows(model, experiment: str, data_dir) -> list[dict[str, object]]:
    """``tools.edge_effect.measure`` of ``model`` on the test frames (2 per scene) of a 96x96 store."""
    cfg = compose([
        f"+experiment={experiment}", "capacity=cpu", "data=tiny", "data.name=bundled_f",
        f"paths.data_dir={data_dir}",
        "data.width=96", "data.height=96", "data.segments=1", "data.frames_per_segment=4",
        "data.test_fraction=0.5", "data.val_clips=0", "data.clip_len=2",  # 2 test frames, 2 others
        "data.ref_spp=512", "data.ref_quality.target_db=null",
        "+scene@data.scenes.cornell-box-picture=cornell-box-picture",
        f"data.train_scenes=[{','.join(SCENES)}]", f"data.test_scenes=[{','.join(SCENES)}]",
    ])
    store = StoreBuilder.from_cfg(cfg, overrides=[])
    buffers = run_buffers(model.required_buffers(), cfg.budget)
    # the test frames only (the first ones of each sequence): nothing here reads the other two
    tests = splits.test_frame_count(store.n_frames, cfg.data.test_fraction)
    store.ensure(buffers, progress=False, selection=Selection(frames=(0, tests)))
    datamodule = MCDDataModule(cfg, store, buffers, model.window)
    datamodule.setup("test")
    return measure(DenoiseModule(cfg, model, None), datamodule.test_dataloader())


def _per_scene(rows: list[dict[str, object]], key: str) -> dict[str, float]:
    return {s: float(np.mean([r[key] for r in rows if r["scene"] == s])) for s in SCENES}


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("data")


@pytest.fixture(scope="module")
def f_rows(data_dir) -> list[dict[str, object]]:
    loaded = load("F-cpu-small")
    return _rows(loaded.model, loaded.experiment, data_dir)


@pytest.mark.slow
def test_bundled_f_beats_its_input_without_a_colour_cast(f_rows):
    assert sorted({r["scene"] for r in f_rows}) == sorted(SCENES)
    for r in f_rows:
        assert r["psnr"] > r["input_psnr"], r
        assert r["colour_shift"] < 0.05, r


@pytest.mark.slow
def test_bundled_f_has_no_border_artefact(f_rows, data_dir):
    effect = _per_scene(f_rows, "edge_effect")
    assert np.mean(list(effect.values())) >= -1.0, effect
    if not HAS_PYOIDN:
        pytest.skip("pyoidn is not installed (optional: pip install 'mcd[oidn]'): no per-scene bound")
    cfg = compose(["+experiment=oidn"])
    oidn = _per_scene(_rows(build(cfg).eval(), "oidn", data_dir), "edge_effect")
    assert all(effect[s] >= oidn[s] for s in SCENES), (effect, oidn)

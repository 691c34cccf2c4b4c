"""A short real training of row F on a 64x64 Cornell box (the ``tiny`` profile's scene, light and size): F's
output beats its noisy input on rMSE, and its sampling map's border ring is not brighter than the content
explains (docs/method.md "Adaptive sampling" step 6, "Kernel pool"; the runs: notes/dark_regions.md).

Before the fixes F's output had 2-4x the input's rMSE on this scene from the first steps on (a bright ring
around the ceiling light: the kernel pool's blur of the light, the residual F_d's correction of it and the
frame-mean match's bands) and its map spent 2-5x the interior's samples on the top row and the left column
(zero padding in ``F_s``). The README's full training is measured in docs/method.md.

The fixtures start F from He's initialisation (``method.init=he``, docs/method.md "Initialisation"): under the
default one, every seed tried (0-2) ends these 100 steps with a collapsed map, exactly 3 spp on every pixel,
on which the ring check would hold whatever the sampler's padding; under ``he`` the map is alive, and the ring
test first asserts that it is. The ring test's F also has ``F_d`` read the sampling map
(``method.denoiser_reads_map=true``, F's default before the scaling study; docs/method.md "F against the
paper"): with the paper's inputs the map of these 100 steps collapses too (spread 0 on the three frames, seed
0; 0.49-0.55 with the map read), while at 1000 steps on ``tiny`` the study found as many collapsed seeds with
it as without (notes/scaling_plan.md). The ring is ``F_s``'s, whatever ``F_d`` reads.
"""


import numpy as np
import pandas as pd
import pytest

from mcd.data.exr import read_exr
from mcd.data.store import StoreReader
from tests.conftest import compose_cfg, mcd_run

#: The ``tiny`` profile narrowed to the Cornell box over 16 frames: 3 test frames, 1 validation clip.
STORE = ["data=tiny", "data.name=test64", "data.frames_per_segment=8", "data.train_scenes=[cbox]",
         "data.test_scenes=[cbox]"]
#: Steps of the training: before the fixes F failed both checks at 200 steps (and at every budget measured);
#: at 100, F's rMSE is 0.34-0.39x its input's on the three test frames (seed 0, the defaults of the scaling
#: study's decision; before it, 0.33-0.38x at 100 and 0.29-0.32x at 200).
STEPS = 100
#: Below this spread (standard deviation over mean) a map is collapsed (docs/benchmark.md "Sampling-map
#: health"): uniform, so its ring would say nothing about the sampler.
ALIVE = 0.05
#: Width of each side of the sampling map's border ring, in pixels.
RING = 2
#: How much brighter than the content's ratio (or than the interior) a side may be (a trained map is not
#: exact).
SLACK = 1.25


def side_ratios(image: np.ndarray) -> dict[str, float]:
    """Per side (top, bottom, left, right), the mean of ``image`` (``H x W``) over that side's ``RING``-pixel
    band over its mean inside the ring."""
    sides = {"top": np.s_[:RING, :], "bottom": np.s_[-RING:, :], "left": np.s_[:, :RING],
             "right": np.s_[:, -RING:]}
    inner = float(image[RING:-RING, RING:-RING].mean())
    return {side: float(image[band].mean()) / inner for side, band in sides.items()}


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory):
    """The store's folder, shared by the module's trainings: the first renders it, the others read it."""
    return tmp_path_factory.mktemp("trained_f_data")


def train_f(root, data_dir, *method: str):
    """Row F (with ``method`` overrides), from He's initialisation (module docstring), trained ``STEPS``
    steps on the 64x64 Cornell box in ``data_dir`` into ``root`` and tested on its test frames: its run
    directory and the store."""
    overrides = [*STORE, f"paths.data_dir={data_dir}"]
    # One thread, as every test's command (mcd_run): two workers each running this with two threads on CI's
    # two cores spun OpenMP's waits past the timeout
    proc = mcd_run("+experiment=F", "method.init=he", *method, *overrides, f"train.max_steps={STEPS}",
                   "train.max_minutes=null", "train.sample_frames=[0,1,2]",
                   "trainer.enable_progress_bar=false", f"hydra.run.dir={root / 'F'}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    return root / "F", StoreReader.from_cfg(compose_cfg(*overrides))


@pytest.fixture(scope="module")
def f_run(tmp_path_factory, data_dir):
    """Row F as configured."""
    return train_f(tmp_path_factory.mktemp("trained_f"), data_dir)


@pytest.fixture(scope="module")
def f_map_run(tmp_path_factory, data_dir):
    """Row F with ``F_d`` reading the sampling map, whose map stays alive over these steps (module
    docstring)."""
    return train_f(tmp_path_factory.mktemp("trained_f_map"), data_dir, "method.denoiser_reads_map=true")


@pytest.mark.slow
def test_f_beats_its_noisy_input_on_rmse(f_run):
    """rMSE, on every test frame. FLIP is not asserted: at this budget F's output is smoother than the
    reference on the flat walls and the boxes' edges, which FLIP weighs more than the input's fine noise; the
    README's full training is measured against the input's FLIP in notes/dark_regions.md."""
    run, _ = f_run
    frames = pd.read_csv(run / "frames.csv")
    assert len(frames) == 3
    assert (frames["rmse"] < frames["input_rmse"]).all(), frames.to_string()


@pytest.mark.slow
def test_the_border_ring_of_the_sampling_map_is_explained_by_the_content(f_map_run):
    """Each side's map-to-interior ratio against that of the per-pixel relative error (rMSE's terms) of a
    1-spp render, the error more samples would lower: the top rows of this frame are the dark ceiling, where
    that error is 3.7x the interior's, so more samples there are the content's due; the other sides hold
    less error than the interior, and the zero-padded sampler gave them 1.3-1.45x its samples at 200 steps
    (2-5x after the README's training). At 100 steps from He's initialisation (seed 0, the
    ``rms_soft`` head, ``F_d`` reading the map) the top side is 1.6x the interior against the content's
    3.7x, the others 0.64-0.74x. The check guards against the gross ring (1.3-5x), not the padding choice
    alone: with ``method.sampler_padding=zeros`` and the settings before the scaling study (``rms_centred``)
    the sides were 0.69-0.90x at 100 steps and 0.69-0.83x at 200, under the slack too."""
    run, store = f_map_run
    maps, errors = [], []
    for frame in range(3):
        maps.append(read_exr(run / "samples" / "cbox" / f"{frame:04d}_sampling_map.exr")[..., 0])
        ref, c1 = store.load("cbox", frame, "ref"), store.load("cbox", frame, "c1")
        errors.append(((c1.astype(np.float64) - ref) ** 2 / (ref.astype(np.float64) ** 2 + 1e-2)).mean(-1))
    for frame, image in enumerate(maps):
        assert image.std() / image.mean() >= ALIVE, f"frame {frame}: the map is collapsed (uniform)"
    content = side_ratios(np.mean(errors, axis=0))
    for side, spent in side_ratios(np.mean(maps, axis=0)).items():
        assert spent <= SLACK * max(1.0, content[side]), \
            f"{side}: map / interior {spent:.2f}, content's {content[side]:.2f}"

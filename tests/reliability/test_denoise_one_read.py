"""Campaign 10, part 2 (notes/reliability_campaigns.md): how ``mcd-denoise`` reads a sequence before the work.

- The exposure's outlier warning (fireflies clamped, ``mcd.data.exposure.FrameExposure.warn_outliers``) was
  given for frame 0 only (``warn=i == 0``): where a black frame 0 left the exposure to frame 1, frame 1's
  fireflies moved it without a word. It is given now for the frame whose exposure is taken.
- Every frame's colour was read twice before any work (``check_frames``, then ``_first_exposure``) and a
  depth layer again for ``_depth_scale``: one read pass (:func:`mcd.denoise.frames.check_frames`, which
  returns what it measured) serves all three, and the outputs are those of the earlier reads.
- A frame ``f0002.EXR`` (not ``.exr`` in lower case) was left out of its folder's sequence without a word; a
  warning names it now.

``mcd-denoise`` runs for real on the bundled U-Net."""

from __future__ import annotations

import logging
from collections import Counter

import numpy as np
import pytest

from mcd.data.exr import read_exr
from mcd.denoise import frames as frames_module
from mcd.denoise.cli import run
from mcd.denoise.frames import LAYERS, read_frame, write_layers
from tests.reliability.denoise_helpers import write_frames


def _denoise(folder, out):
    return run([str(folder), "-o", str(out), "--checkpoint", "unet-cpu-small", "--no-progress"])


def _rewrite(path, colour=None, depth=None):
    fr = read_frame(path, set(LAYERS))
    write_layers(path, fr["colour"] if colour is None else colour,
                 {"albedo": fr["albedo"], "normal": fr["normal"],
                  "depth": fr["depth"] if depth is None else depth})


def test_the_outlier_warning_names_the_frame_that_sets_the_exposure(tmp_path, caplog):
    paths = write_frames(tmp_path / "in", n=3, size=(64, 64), seed=3)
    _rewrite(paths[0], colour=np.zeros((64, 64, 3), np.float32))  # black: frame 1 sets the exposure
    colour = read_frame(paths[1], set())["colour"]
    colour[10, 20] = 1e6
    _rewrite(paths[1], colour=colour)
    with caplog.at_level(logging.WARNING, logger="mcd.data.exposure"):
        _denoise(tmp_path / "in", tmp_path / "out")
    assert f"{paths[1]}: 3 of 12288 values above" in caplog.text, caplog.text
    assert "would have moved it from x" in caplog.text


def test_a_firefly_in_a_frame_whose_exposure_is_not_taken_gives_no_warning(tmp_path, caplog):
    paths = write_frames(tmp_path / "in", n=3, size=(64, 64), seed=3)
    colour = read_frame(paths[2], set())["colour"]
    colour[10, 20] = 1e6  # frame 0 sets the exposure; frame 2's firefly moves nothing
    _rewrite(paths[2], colour=colour)
    with caplog.at_level(logging.WARNING, logger="mcd.data.exposure"):
        _denoise(tmp_path / "in", tmp_path / "out")
    assert "clamped for the exposure" not in caplog.text, caplog.text


@pytest.mark.parametrize("sky", [False, True])
def test_each_file_is_read_once_before_the_work_and_the_outputs_are_unchanged(tmp_path, monkeypatch, sky):
    paths = write_frames(tmp_path / "in", n=3, size=(32, 32), seed=4)
    if sky:  # frame 0 hits nothing: frame 1 gives the depth scale
        _rewrite(paths[0], depth=np.zeros((32, 32, 1), np.float32))
    reads: Counter[str] = Counter()
    real = frames_module.read_channels

    def counted(path, size=None):
        reads[path.name] += 1
        return real(path, size)

    monkeypatch.setattr(frames_module, "read_channels", counted)
    report = _denoise(tmp_path / "in", tmp_path / "out")
    assert reads == Counter({p.name: 2 for p in paths}), reads  # the check's read, and the denoise's
    monkeypatch.setattr(frames_module, "read_channels", real)
    scan = frames_module.check_frames(paths, set(LAYERS), 0.5)
    assert report["exposure"] == pytest.approx(scan.exposures[0].exposure)
    assert scan.depth_from == (1 if sky else 0)
    # the outputs of the one read equal those of a sequence object that reads its frames itself
    seq = frames_module.FrameSequence(paths, set(LAYERS), "c4", 0.5)
    assert (seq.exposure, seq.depth_scale) == (report["exposure"], scan.depth_scale)
    assert np.isfinite(read_exr(tmp_path / "out" / "f0001.exr")).all()


def test_a_frame_whose_suffix_is_not_lower_case_is_named(tmp_path, caplog):
    """``f0002.EXR`` beside ``f0000.exr`` and ``f0001.exr`` was left out of the sequence without a word."""
    paths = write_frames(tmp_path / "in", n=3, size=(16, 16))
    paths[2].rename(paths[2].with_suffix(".EXR"))
    with caplog.at_level(logging.WARNING, logger="mcd.denoise.frames"):
        report = _denoise(tmp_path / "in", tmp_path / "out")
    assert report["frames"] == 2
    assert "f0002.EXR: not '.exr' in lower case" in caplog.text, caplog.text

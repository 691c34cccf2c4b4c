"""How a scene's frame sequence splits into test, validation and training frames (docs/benchmark.md, "Data
protocol"): the first ``round(data.test_fraction * n)`` frames are the test sequence (at least one), the next
``data.val_clips`` clips of ``data.clip_len`` frames validate, the remaining frames train: whole clips that
start every ``data.train_clip_stride`` frames (null: ``clip_len``, the paper's non-overlapping clips, Sec.
5.1; 1: every clip of the training frames, for a profile with few frames: docs/training.md "Overlapping
training clips"). One place for this rule: the datamodule, the training-store packer and the plan read it, and
the store builder renders the test frames' references to ``data.ref_quality`` (docs/data.md, "Reference
quality")."""

from __future__ import annotations

from typing import Any

from omegaconf import DictConfig

from mcd.core.config_rules import checked


def test_frame_count(n: int, test_fraction: float) -> int:
    """How many of a sequence's ``n`` frames (its first ones) are test frames."""
    return max(1, int(round(test_fraction * n)))


def clip_stride(clip_len: int, train_stride: Any) -> int:
    """The training clips' stride: ``train_stride`` (``data.train_clip_stride``) as a whole number from 1 to
    ``clip_len``, or ``clip_len`` for None; else ValueError naming the key and what to give."""
    if train_stride is None:
        return clip_len
    try:
        stride = int(train_stride)
    except (TypeError, ValueError):
        stride = 0
    if str(stride) != str(train_stride).strip() or not 1 <= stride <= clip_len:
        raise ValueError(f"data.train_clip_stride={train_stride}: give a whole number from 1 to {clip_len} "
                         "(data.clip_len), or null for non-overlapping clips")
    return stride


def split_frames(n: int, test_fraction: float, val_clips: int, clip_len: int,
                 train_stride: int | None = None) -> dict[str, list[list[int]]]:
    """Frame indices of a sequence: ``test`` (one whole sequence), ``val`` and ``train`` (clips; training
    clips start every ``train_stride`` frames after the validation clips, None: ``clip_len``)."""
    stride = clip_stride(clip_len, train_stride)
    n_test = test_frame_count(n, test_fraction)
    rest = list(range(n_test, n))
    train = rest[val_clips * clip_len :]
    if len(train) < clip_len:
        raise ValueError(
            f"a {n}-frame sequence leaves {len(rest)} frames after the {n_test} test frames: not enough for "
            f"{val_clips} validation clip(s) and one training clip of {clip_len} frames; raise "
            "data.frames_per_segment or data.segments, or lower data.val_clips / data.clip_len"
        )
    return {"test": [list(range(n_test))],
            "val": [rest[i * clip_len : (i + 1) * clip_len] for i in range(val_clips)],
            "train": [train[i : i + clip_len] for i in range(0, len(train) - clip_len + 1, stride)]}


def split_of(n: int, data_cfg: Any) -> dict[str, list[list[int]]]:
    """:func:`split_frames` of an ``n``-frame sequence with a data profile's settings (``data.*``)."""
    return split_frames(n, float(data_cfg.get("test_fraction", 0.2)), int(data_cfg.val_clips),
                        int(data_cfg.clip_len), data_cfg.get("train_clip_stride"))


def check_crops(cfg: DictConfig) -> None:
    """ValueError unless ``data.train_crop`` fits the frames and ``data.train_crop_at_edge`` is a
    probability (its rule in mcd/core/config_rules.py)."""
    d = cfg.data
    checked("data.train_crop", d.train_crop)
    checked("data.train_crop_at_edge", d.get("train_crop_at_edge", 0.0))
    crop, w, h = int(d.train_crop), int(d.width), int(d.height)
    if crop > min(w, h):
        raise ValueError(f"data.train_crop={crop} is larger than the {w}x{h} frames of profile {d.name}: "
                         f"give data.train_crop <= {min(w, h)}")

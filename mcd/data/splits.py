"""How a scene's frame sequence splits into test, validation and training frames (docs/benchmark.md, "Data
protocol"): the first ``round(data.test_fraction * n)`` frames are the test sequence (at least one), the next
``data.val_clips`` clips of ``data.clip_len`` frames validate, the remaining whole clips train. One place for
this rule: the datamodule reads it, and the store builder renders the test frames' references to
``data.ref_quality`` (docs/data.md, "Reference quality")."""

from __future__ import annotations


def test_frame_count(n: int, test_fraction: float) -> int:
    """How many of a sequence's ``n`` frames (its first ones) are test frames."""
    return max(1, int(round(test_fraction * n)))


def split_frames(n: int, test_fraction: float, val_clips: int, clip_len: int) -> dict[str, list[list[int]]]:
    """Frame indices of a sequence: ``test`` (one whole sequence), ``val`` and ``train`` (clips)."""
    n_test = test_frame_count(n, test_fraction)
    rest = list(range(n_test, n))
    clips = [rest[i : i + clip_len] for i in range(0, len(rest) - clip_len + 1, clip_len)]
    if len(clips) < val_clips + 1:
        raise ValueError(
            f"a {n}-frame sequence leaves {len(rest)} frames after the {n_test} test frames: not enough for "
            f"{val_clips} validation clip(s) and one training clip of {clip_len} frames; raise "
            "data.frames_per_segment or data.segments, or lower data.val_clips / data.clip_len"
        )
    return {"test": [list(range(n_test))], "val": clips[:val_clips], "train": clips[val_clips:]}

"""Campaign 13 (docs/reliability.md, "Campaign fixes"; campaign 12's left medium): a resume in another
precision says so, and the run's record names the precision of every training segment.

An interrupted run trained in ``bf16-mixed`` (what ``trainer.precision=auto`` resolves to on a CPU with
native bf16) resumed with ``ckpt_path=auto trainer.precision=32-true`` trained on, exit 0, and
``metrics.json`` named ``32-true`` alone. The resume is still allowed (``auto`` resolves per machine, so a
resume on another machine may change it), but ``mcd.lit.segments.TrainingSegments`` now records each
segment's resolved precision in ``segments`` and warns when it changes.
"""

from __future__ import annotations

import json
import logging
import time

import pytest
import torch

from mcd.run import train_and_test
from tests.conftest import compose_cfg

CHOICES = {"data": "tiny"}


@pytest.mark.slow
def test_a_resume_in_another_precision_is_named_per_segment(own_interrupted, caplog):
    run, overrides, _ = own_interrupted  # row A killed after its checkpoint (one epoch)

    state = torch.load(run / "checkpoints" / "last.ckpt", weights_only=True, map_location="cpu")
    [before] = state["callbacks"]["TrainingSegments"]["segments"]
    other = "32-true" if before["precision"] != "32-true" else "bf16-mixed"
    with caplog.at_level(logging.WARNING, logger="mcd.lit.segments"):
        resumed = compose_cfg(*overrides, "train.epochs=2", "ckpt_path=auto", f"trainer.precision={other}")
        train_and_test(resumed, run, CHOICES, time.perf_counter())
    metrics = json.loads((run / "metrics.json").read_text())
    assert [s["precision"] for s in metrics["segments"]] == [before["precision"], other]
    assert metrics["precision"] == other
    assert f"trained in precision {before['precision']}; this process trains in {other}" in caplog.text

    from mcd.reporting.provenance import _segment_text  # the report names each segment's precision
    assert [_segment_text(s).split(" in ")[-1].split(",")[0] for s in metrics["segments"]] == [
        before["precision"], other]

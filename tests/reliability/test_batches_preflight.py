"""Campaign 11, part 1 (docs/reliability.md, "Campaign fixes"): a share of an epoch's batches that is no
batch is refused before anything is rendered.

``mcd.run ... train.limit_train_batches=0.5`` with one training clip per epoch rendered the whole store
(c4, ref, depth, normal, albedo x12), then Lightning refused it when training started ("0.5 * 1 < 1"), exit 1
(high by the campaigns' rule: a crash after work a check could have caught; days of rendering on
``data=paper``). :func:`mcd.config.preflight.check_batches` now names the key, the batches per epoch and
what to give, before the store is made; a share that is at least one batch, and an integer count, train.
"""

from __future__ import annotations

import time

import pytest

from mcd.config.preflight import check_batches
from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides


def test_a_share_that_is_no_batch_is_refused_before_rendering(tmp_path):
    overrides = [*store32_overrides(tmp_path / "data"), "+experiment=unet", "capacity=cpu",
                 "train.max_steps=2"]
    cfg = compose_cfg(*overrides, "train.limit_train_batches=0.5")  # 1 clip, batch 4: one batch per epoch
    with pytest.raises(ValueError, match=r"train\.limit_train_batches=0\.5: that share of the 1 training "
                                         r"batch\(es\) per epoch \(1 clip\(s\), train\.batch_size=4\) "
                                         r"is no batch"):
        train_and_test(cfg, tmp_path / "run", {"data": "tiny"}, time.perf_counter())
    assert not (tmp_path / "data").exists()  # nothing rendered
    check_batches(compose_cfg(*overrides, "train.limit_train_batches=1"))  # a count of one batch
    check_batches(compose_cfg(*overrides, "train.limit_train_batches=0.5", "data.frames_per_segment=12",
                              "train.batch_size=1"))  # 0.5 of 14 batches

"""Campaign 11, part 1 (docs/reliability.md, "Campaign fixes"): an accelerator this machine lacks is named
before anything is rendered.

``mcd.run ... trainer.accelerator=gpu`` on a machine without a GPU checked (or rendered) the whole store, then
Lightning failed building the trainer ("No supported gpu backend found!"), naming no key (high by the
campaigns' rule: a crash after work a check could have caught). :func:`mcd.lit.accelerator.check` asks
Lightning's accelerators first and names ``trainer.accelerator`` (or ``trainer.devices``, more devices than
there are) before the store is made.
"""

from __future__ import annotations

import time

import pytest
import torch

from mcd.lit.accelerator import check
from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides


def test_a_missing_accelerator_or_too_many_devices_are_named_before_rendering(tmp_path):
    overrides = [*store32_overrides(tmp_path / "data"), "+experiment=unet", "capacity=cpu",
                 "train.max_steps=2"]
    if torch.cuda.is_available():  # a GPU machine: ask for one device more than it has
        bad, match = ["trainer.accelerator=gpu", f"trainer.devices={torch.cuda.device_count() + 1}"], \
            r"trainer\.devices=\d+: this machine has \d+ gpu device\(s\)"
    else:
        bad, match = ["trainer.accelerator=gpu"], r"trainer\.accelerator=gpu: this machine has no such device"
    with pytest.raises(ValueError, match=match):
        train_and_test(compose_cfg(*overrides, *bad), tmp_path / "run", {"data": "tiny"}, time.perf_counter())
    assert not (tmp_path / "data").exists()  # nothing rendered
    with pytest.raises(ValueError, match=r"trainer\.accelerator=banana: give one of auto, cpu, gpu"):
        check("banana", 1)
    check("cpu", 1)
    check("auto", 1)

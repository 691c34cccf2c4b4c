"""Campaign 11, part 1 (docs/reliability.md, "Campaign fixes"): ``ckpt_path`` naming a run's folder says so.

``mcd.run ckpt_path=<a run directory>`` said "no such checkpoint file" of a folder that exists (low, as
campaign 5's ``/dev/zero``); now it says the path is a folder and, where it is a run's, names its
``checkpoints/last.ckpt`` to give, before anything is rendered.
"""

from __future__ import annotations

import time

import pytest

from mcd.run import train_and_test
from tests.conftest import compose_cfg, store32_overrides


def test_a_run_folder_as_ckpt_path_names_its_last_checkpoint(tmp_path):
    run = tmp_path / "finished"
    (run / "checkpoints").mkdir(parents=True)
    (run / "checkpoints" / "last.ckpt").write_bytes(b"")
    cfg = compose_cfg(*store32_overrides(tmp_path / "data"), "+experiment=unet", "capacity=cpu",
                      "train.max_steps=1", f"ckpt_path={run}")
    with pytest.raises(FileNotFoundError, match=rf"ckpt_path={run}: a folder, not a checkpoint file \(give "
                                                rf"{run / 'checkpoints' / 'last.ckpt'}\)"):
        train_and_test(cfg, tmp_path / "run", {"data": "tiny"}, time.perf_counter())
    assert not (tmp_path / "data").exists()

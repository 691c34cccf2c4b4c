"""Campaign 8 (docs/reliability.md): a run resumed from another directory's checkpoint leaves that directory
as it was, and no run trains past its step budget on a resume.

- A finished run trained further from its ``last.ckpt`` into a new directory with an epoch budget whose last
  epoch is not validated inside the fit (``train.epochs=3 train.val_every=2``) deleted the finished run's
  ``best-step*.ckpt``, the checkpoint its ``metrics.json`` names as tested: Lightning restores the best
  checkpoint's path from the file even into another folder, and ``mcd.lit.budget.finish``, validating the
  final weights, unlinked it when it kept them as the better ones. Now a best-checkpoint path from another
  folder is forgotten at the start of training, and ``finish`` deletes only in the run's own folder.
- A run directory copied elsewhere, its test lost (killed during the test: ``last.ckpt`` at the budget, no
  ``metrics.json``) and resumed with ``ckpt_path=auto`` trained one step past its budget ("stopped by the step
  budget (train.max_steps=2) after 3 steps"); a checkpoint at or past the budget now trains no step and is
  tested as it is (which without the fix above made ``finish`` validate and delete the original's best).
"""

from __future__ import annotations

import hashlib
import json
import shutil

import pytest

from tests.conftest import mcd_run, store32_overrides

RUN = ["+experiment=unet", "train.sample_frames=[]", "trainer.enable_progress_bar=false"]


def _digests(folder) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name != "run.lock"}


@pytest.mark.slow
def test_a_run_resumed_from_another_runs_checkpoint_leaves_that_run_as_it_was(cbox_store, tmp_path):
    data = store32_overrides(cbox_store[1].data_dir)
    first = tmp_path / "first"
    proc = mcd_run(*RUN, *data, "train.max_steps=2", f"hydra.run.dir={first}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    before = _digests(first)
    assert any(name.startswith("checkpoints/best-step") for name in before)

    further = tmp_path / "further"  # trained on from the finished run's last checkpoint (2 epochs of 1 step)
    proc = mcd_run(*RUN, *data, "train.max_steps=null", "train.epochs=3", "train.val_every=2",
                   f"ckpt_path={first / 'checkpoints' / 'last.ckpt'}", f"hydra.run.dir={further}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert _digests(first) == before  # every file of the finished run, its best checkpoint included
    record = json.loads((further / "metrics.json").read_text())
    assert record["train_steps"] > 2 and record["checkpoint"].startswith(str(further))

    copy = tmp_path / "copy"  # a copy of the run, its test lost (killed during the test), resumed
    shutil.copytree(first, copy)
    (copy / "metrics.json").unlink()
    proc = mcd_run(*RUN, *data, "train.max_steps=2", "ckpt_path=auto", f"hydra.run.dir={copy}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert _digests(first) == before  # every file of the finished run, its best checkpoint included
    record = json.loads((copy / "metrics.json").read_text())
    assert record["train_steps"] == 2 and record["stop_reason"] == "max_steps"  # no step past the budget
    assert record["checkpoint"].startswith(str(copy))

    assert _digests(first) == before  # every file of the finished run, its best checkpoint included

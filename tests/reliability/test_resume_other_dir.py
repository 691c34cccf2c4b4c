"""Campaign 8 (docs/reliability.md): a run resumed from another directory's checkpoint leaves that directory
as it was, and no run trains past its step budget on a resume.

- ``ckpt_path=<finished run>/checkpoints/last.ckpt hydra.run.dir=<new dir>`` (how a finished run is trained
  further: a rerun into it is skipped) deleted the finished run's ``best-step*.ckpt``, the checkpoint its
  ``metrics.json`` names as tested: Lightning restores the best checkpoint's path from the file even into
  another folder, and ``mcd.lit.budget.finish`` unlinked it when it found a better one. A run directory copied
  elsewhere and resumed with ``ckpt_path=auto`` did the same to the original.
- A run killed after its last step (during its test) and resumed with ``ckpt_path=auto`` trained one step past
  its budget (``train.max_steps=2``: "stopped by the step budget (train.max_steps=2) after 3 steps"); a
  checkpoint at or past the budget now trains no step and is tested as it is.
"""

from __future__ import annotations

import hashlib
import json
import shutil

from tests.conftest import store32_overrides
from tests.test_run import mcd_run

RUN = ["+experiment=unet", "train.sample_frames=[]", "trainer.enable_progress_bar=false"]


def _digests(folder) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file() and p.name != "run.lock"}


def test_a_run_resumed_from_another_runs_checkpoint_leaves_that_run_as_it_was(cbox_store, tmp_path):
    data = store32_overrides(cbox_store[1].data_dir)
    first = tmp_path / "first"
    proc = mcd_run(*RUN, *data, "train.max_steps=2", f"hydra.run.dir={first}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    before = _digests(first)
    assert any(name.startswith("checkpoints/best-step") for name in before)

    further = tmp_path / "further"  # trained on from the finished run's last checkpoint
    proc = mcd_run(*RUN, *data, "train.max_steps=4", f"ckpt_path={first / 'checkpoints' / 'last.ckpt'}",
                   f"hydra.run.dir={further}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    record = json.loads((further / "metrics.json").read_text())
    assert record["train_steps"] == 4 and record["checkpoint"].startswith(str(further))

    copy = tmp_path / "copy"  # a copy of the run, its test lost (killed during the test), resumed
    shutil.copytree(first, copy)
    (copy / "metrics.json").unlink()
    proc = mcd_run(*RUN, *data, "train.max_steps=2", "ckpt_path=auto", f"hydra.run.dir={copy}")
    assert proc.returncode == 0, proc.stderr[-4000:]
    record = json.loads((copy / "metrics.json").read_text())
    assert record["train_steps"] == 2 and record["stop_reason"] == "max_steps"  # no step past the budget
    assert record["checkpoint"].startswith(str(copy))

    assert _digests(first) == before  # every file of the finished run, its best checkpoint included

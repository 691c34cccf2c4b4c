"""Campaign 10, part 1 (docs/reliability.md, "Campaign fixes"): a transfer's source and fine-tuning are part
of its job.

A finished transfer (``transfer.init_from=<run> transfer.finetune_epochs=0``) rerun into its directory with
``transfer.finetune_epochs=1``, or from another source run, was skipped ("skip: ... already holds a complete
metrics.json", exit 0): the user's fine-tuned transfer never ran, and the directory's ``metrics.json`` is the
other transfer's. Now both are refused as another job, naming ``transfer.*``, and the finished run keeps its
bytes; the same transfer again is skipped as before.
"""

from __future__ import annotations

import shutil

import pytest

from tests.conftest import UNET_RUN, mcd_run, store32_overrides

TRANSFER = ["+experiment=unet", "capacity=cpu", "trainer.enable_progress_bar=false",
            "+scene@data.scenes.cornell-box-picture=cornell-box-picture",
            "data.transfer_scenes=[cornell-box-picture]"]


@pytest.mark.slow
def test_another_source_or_fine_tuning_is_another_job(unet_run, tmp_path):
    source, _ = unet_run
    data = [*store32_overrides(tmp_path / "data"), *UNET_RUN]
    run = tmp_path / "transfer"
    first = mcd_run(*TRANSFER, *data, f"transfer.init_from={source}", f"hydra.run.dir={run}")
    assert first.returncode == 0, first.stderr[-3000:]
    finished = (run / "metrics.json").read_bytes()

    other = tmp_path / "other_source"
    shutil.copytree(source, other)
    for change, named in ((["transfer.finetune_epochs=1", f"transfer.init_from={source}"],
                           "transfer.finetune_epochs: 0 there, 1 here"),
                          ([f"transfer.init_from={other}"], "transfer.init_from: ")):
        proc = mcd_run(*TRANSFER, *data, *change, f"hydra.run.dir={run}")
        log = proc.stdout + proc.stderr
        assert proc.returncode != 0 and "skip:" not in log, log[-3000:]
        assert f"{run} holds a finished run of another job" in proc.stderr and named in proc.stderr
        assert (run / "metrics.json").read_bytes() == finished

    again = mcd_run(*TRANSFER, *data, f"transfer.init_from={source}", f"hydra.run.dir={run}")
    assert again.returncode == 0 and "skip:" in again.stdout + again.stderr

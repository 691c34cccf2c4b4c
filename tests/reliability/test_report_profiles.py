"""A report of runs from two data profiles makes no finding across them and names them (``mcd.report``
``mixed_profiles_note``): runs of ``tiny`` and ``small`` reported together gave findings comparing a method of
one profile with a method of the other ("F ... dB above U-Net: holds"), and never said the profiles
differed."""

from __future__ import annotations

import json
import shutil

import pytest

from mcd.report import main
from tests.conftest import mcd_run, store32_overrides

RUN = ["train.epochs=1", "train.batch_size=1", "train.sample_frames=[]", "trainer.enable_progress_bar=false"]


def _small(data_dir) -> list[str]:
    """The 32x32 Cornell-box overrides on the ``small`` profile (its own store; no transfer scene)."""
    return [*(o if o != "data=tiny" else "data=small" for o in store32_overrides(data_dir)),
            "data.transfer_scenes=[]"]


@pytest.mark.slow
def test_runs_of_two_profiles_give_no_cross_profile_finding_and_name_both(cbox_store, tmp_path):
    sweep = tmp_path / "multirun"
    tiny = mcd_run("+experiment=F", "capacity=cpu", *store32_overrides(cbox_store[1].data_dir), *RUN,
                   f"hydra.run.dir={sweep / 'f_tiny'}")
    assert tiny.returncode == 0, tiny.stderr[-4000:]
    small = mcd_run("+experiment=unet", "capacity=cpu", *_small(tmp_path / "data_small"), *RUN,
                    f"hydra.run.dir={sweep / 'unet_small'}")
    assert small.returncode == 0, small.stderr[-4000:]
    profiles = {d: json.loads((sweep / d / "metrics.json").read_text())["data_profile"]
                for d in ("f_tiny", "unet_small")}
    assert profiles == {"f_tiny": "tiny", "unet_small": "small"}

    out = tmp_path / "reports"
    main([str(sweep), "--out", str(out), "--name", "mixed", "--bench", str(tmp_path / "none"), "--no-viewer"])
    assert json.loads((out / "mixed" / "findings.json").read_text())["findings"] == []
    readme = (out / "mixed" / "README.md").read_text()
    findings = readme.split("## Findings", 1)[1].split("## Table 1", 1)[0]
    assert "None: the runs come from 2 data profiles, `small` (1 run), `tiny` (1 run)" in findings
    assert "U-Net" not in findings and "holds" not in findings

    # one profile alone still gets its findings
    shutil.rmtree(sweep / "unet_small")
    main([str(sweep), "--out", str(out), "--name", "one", "--bench", str(tmp_path / "none"), "--no-viewer"])
    assert json.loads((out / "one" / "findings.json").read_text())["findings"] != []

"""The scaling report's cells hold one recipe's seeds, each with a score (docs/reliability.md, "Campaign
fixes"; ``mcd.reporting.scaling.grid.read``). A run whose ``psnr`` is null (``mcd.run`` writes a NaN score so)
counted as a seed of its cell (``n`` 2, band "range") while the mean came from the other seed alone; a run of
the same profile name with another capacity profile (or other data settings: ``data.width``, samples, ...) was
averaged with the others as one more seed. Both are now left out, each named with why."""

from __future__ import annotations

import json
import shutil

import pytest

from mcd.reporting.runs import find_runs
from mcd.reporting.scaling import grid
from tests.conftest import mcd_run, store32_overrides

RUN = ["+experiment=unet", "train.max_steps=2", "train.batch_size=1", "train.sample_frames=[]",
       "trainer.enable_progress_bar=false"]


@pytest.fixture(scope="module")
def runs(cbox_store, tmp_path_factory):
    """Seeds 0 and 1 of the U-Net at 2 steps, capacity cpu, and seed 2 at capacity paper."""
    root = tmp_path_factory.mktemp("scaling")
    base = [*RUN, *store32_overrides(cbox_store[1].data_dir)]
    for seed, capacity in ((0, "cpu"), (1, "cpu"), (2, "paper")):
        proc = mcd_run(*base, f"seed={seed}", f"capacity={capacity}", f"hydra.run.dir={root / f's{seed}'}")
        assert proc.returncode == 0, proc.stderr[-3000:]
    return root


@pytest.mark.slow
def test_a_seed_without_a_psnr_or_of_another_capacity_is_left_out_of_its_cell(runs, tmp_path):
    root = tmp_path / "runs"
    shutil.copytree(runs, root)
    whole = grid.cells(grid.read(find_runs([root])))
    assert whole.loc[0, "n"] == 2 and whole.loc[0, "seeds"] == "0,1"  # seed 2 differs in capacity
    record = root / "s1" / "metrics.json"
    metrics = json.loads(record.read_text())
    record.write_text(json.dumps({**metrics, "psnr": None}))  # as mcd.run records a NaN score
    g = grid.read(find_runs([root]))
    cells = grid.cells(g)
    assert len(cells) == 1 and cells.loc[0, "n"] == 1 and cells.loc[0, "seeds"] == "0"
    assert cells.loc[0, "band"] == "none"
    why = {line.split("`")[1].rsplit("/", 1)[-1]: line for line in g.left_out}
    assert sorted(why) == ["s1", "s2"]
    assert "no PSNR" in why["s1"] and "capacity_profile" in why["s2"] and "s0" in why["s2"]

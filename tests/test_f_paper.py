"""``+experiment=F_paper``: row F with every addition of this project off (docs/method.md "F against the
paper"). The table's last column is the one list of those settings: each holds in ``F_paper``'s composed
config, F differs where its default is not already the paper's, and ``F_paper`` trains and tests on a real
32x32 Cornell-box store."""

from __future__ import annotations

import json
import re
import time
from pathlib import Path

import pandas as pd
import pytest
import torch
import yaml
from omegaconf import OmegaConf

from mcd.config.compose import compose
from mcd.config.methods import BY_EXPERIMENT, TABLE1_VARIANTS
from tests.conftest import compose_cfg, store32_overrides

REPO = Path(__file__).resolve().parents[1]
SECTION = "## F against the paper"


def deviation_rows() -> list[tuple[str, str, list[tuple[str, str]]]]:
    """``(what, F's column, [(key, value), ...])`` for each row of docs/method.md's table."""
    text = (REPO / "docs" / "method.md").read_text()
    body = text[text.index(SECTION):]
    body = body[:body.index("\n## ", 1)]
    rows = []
    for line in body.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) != 5 or cells[0] in ("what", "---"):
            continue
        pairs = re.findall(r"`([a-z_.]+)=([^`]+)`", cells[4])
        assert pairs, f"docs/method.md, {SECTION!r}: row {cells[0]!r} names no `key=value` switch"
        rows.append((cells[0], cells[2], pairs))
    return rows


def value(text: str):
    """A switch's value as the config holds it (``null`` -> None, ``0.0`` -> 0.0, ``tanh`` -> "tanh")."""
    return yaml.safe_load(text)


def test_every_listed_deviation_is_off_in_f_paper():
    rows = deviation_rows()
    assert len(rows) >= 12
    paper, ours = compose(["+experiment=F_paper"]), compose(["+experiment=F"])
    assert paper.experiment == "F_paper" and paper.method.name == "two_stage"
    assert [paper.method[s] for s in ("UN", "AS", "KP", "PP", "FG", "SA")] == [True] * 6
    differs = 0
    for what, f_column, pairs in rows:
        for key, text in pairs:
            want = value(text)
            assert OmegaConf.select(paper, key, throw_on_missing=True) == want, f"{what}: {key}"
            if "(default)" not in f_column and not f_column.startswith("off"):
                assert OmegaConf.select(ours, key) != want, f"{what}: F has {key}={want} already"
                differs += 1
    assert differs >= 10
    # everything else is F's: the same recipe (train, loss, capacity) and colour compression
    for key in ("train", "loss", "capacity", "budget"):
        assert paper[key] == ours[key], key
    assert paper.method.colour == ours.method.colour



def flat(cfg) -> dict[str, object]:
    """A composed config as ``{dotted key: value}`` (interpolations left as written)."""
    out: dict[str, object] = {}

    def walk(node, prefix: str) -> None:
        if isinstance(node, dict) and node:
            for k, v in node.items():
                walk(v, f"{prefix}{k}.")
        else:
            out[prefix[:-1]] = node
    walk(OmegaConf.to_container(cfg, resolve=False), "")
    return out


def test_each_of_fs_additions_has_one_experiment_that_puts_back_the_papers_setting():
    """``F_paper_<part>``: F with one row of the table back to the paper's text and nothing else, one
    experiment per row where F differs from the paper, each a variant of F (the scaling report shows
    ``F_paper_<part> - F``, minus what the addition is worth)."""
    ours = flat(compose(["+experiment=F"]))
    rows = {what: dict((k, value(t)) for k, t in pairs) for what, f_column, pairs in deviation_rows()
            if "(default)" not in f_column and not f_column.startswith("off")}
    # rows F took back from the paper after the scaling study: their experiments stay as its records
    records = {e: what for what, f_column, _ in deviation_rows() if "(default)" in f_column
               for e in re.findall(r"`(F_paper_[a-z_]+)`", f_column)}
    found: dict[str, str] = {}
    for path in sorted((REPO / "conf" / "experiment").glob("F_paper_*.yaml")):
        experiment = path.stem
        theirs = flat(compose([f"+experiment={experiment}"]))
        changed = {k: theirs.get(k) for k in set(ours) | set(theirs)
                   if k != "experiment" and ours.get(k) != theirs.get(k)}
        assert theirs["experiment"] == experiment
        assert BY_EXPERIMENT[experiment].variant_of == "F" and BY_EXPERIMENT[experiment].diagnostic
        if experiment in records:
            assert changed == {}, f"{experiment}: F has the paper's {records[experiment]!r}, not {changed}"
            continue
        (what,) = [w for w, switch in rows.items() if switch == changed] or [None]
        assert what, f"{experiment} changes {changed}: no single row of docs/method.md's table"
        assert what not in found, f"{experiment} and {found[what]} both put back {what!r}"
        found[what] = experiment
    assert sorted(found) == sorted(rows), f"rows without an experiment: {sorted(set(rows) - set(found))}"
    assert sorted(records) == ["F_paper_map_input"]
    study = (REPO / "scripts" / "scaling_study.sh").read_text()
    assert all(e in study for e in found.values()), "scripts/scaling_study.sh runs every F_paper_<part>"

def test_f_paper_sits_beside_f_in_table1():
    """A variant of F's Table 1 row, run by the baselines sweep and the current report's baselines stage."""
    entry = BY_EXPERIMENT["F_paper"]
    assert entry.variant_of == "F" and entry.trainable and not entry.table1
    assert TABLE1_VARIANTS["F_paper"] == "F"
    sweep = yaml.safe_load((REPO / "conf" / "sweep" / "baselines.yaml").read_text())
    assert "F_paper" in sweep["hydra"]["sweeper"]["params"]["+experiment"].split(",")
    stage = next(line for line in (REPO / "scripts" / "current_report.sh").read_text().splitlines()
                 if line.strip().startswith("baselines)"))
    assert "F_paper" in stage.split("sweep baselines")[1].split(";;")[0].strip().split(",")


@pytest.mark.slow
def test_f_paper_trains_and_tests_on_real_renders(cbox_store, tmp_path):
    """A few real optimiser steps of F_paper, then the test: its F_d reads ``i_bar`` and ``g`` only (10
    channels), predicts the image, and the record says F_paper."""
    from mcd.models import build
    from mcd.run import train_and_test

    cfg = compose_cfg(*store32_overrides(cbox_store[1].data_dir), "data.train_crop=32", "data.val_crop=32",
                      "train.batch_size=1", "+experiment=F_paper", "train.max_steps=3",
                      "train.max_minutes=null", "train.val_every_steps=3", "train.sample_frames=[]",
                      "trainer.enable_progress_bar=false")
    model = build(cfg)
    first = next(m for m in model.denoiser.unet.encoder.modules() if isinstance(m, torch.nn.Conv2d))
    assert first.in_channels == 3 + 7 and not model.residual and not model.reads_map
    assert model.denoiser_margin == 0 and not model._forward_hooks  # no mean match, no passed misses
    train_and_test(cfg, tmp_path, {}, time.perf_counter())
    m = json.loads((tmp_path / "metrics.json").read_text())
    assert m["experiment"] == "F_paper" and m["train_steps"] == 3 and m["trained"] is True
    assert m["method"]["denoiser_output"] == "direct" and m["method"]["kp"]["head_output"] == "tanh"
    frames = pd.read_csv(tmp_path / "frames.csv")
    assert len(frames) == 2 and frames["psnr"].notna().all()


def test_findings_compare_f_with_baselines_not_with_its_variants_or_diagnostics():
    """A Table 1 where F_paper and an NTASAD diagnostic score above F: the headline and the baselines'
    finding compare F with the methods of the paper's Table 1 only (and DASR's loss variant)."""
    from mcd.reporting import findings

    t1 = pd.DataFrame({"experiment": ["F", "F_paper", "F_warp_previous", "ntasad_no_warp", "rae", "oidn"],
                       "method": ["two_stage", "two_stage", "two_stage", "ntasad", "rae", "oidn"],
                       "PSNR": [26.0, 30.0, 31.0, 32.0, 25.0, 29.0]})
    (head,) = findings.headline(t1)
    assert head.subjects == ("F", "oidn") and head.verdict == "does not hold"
    (base,) = findings.baselines(t1)
    assert base.subjects == ("F", "rae") and base.verdict == "holds so far"

"""The reports index and README.md's results block (mcd/reporting/index.py, docs/benchmark.md "Reports"):
generated from the report folders, the current report marked; the block regenerates to the same text and a
README without its markers is refused before anything is written."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pandas as pd
import pytest

from mcd.report import main as report_main
from mcd.reporting import index

REPO = Path(__file__).resolve().parents[2]


def _report(root: Path, name: str, psnr_f: float) -> Path:
    """A report of ``python -m mcd.report`` on two finished jobs (F and OIDN) of data profile tiny."""
    sweep = root / "multirun" / name
    for exp, psnr in (("F", psnr_f), ("oidn", 30.0)):
        d = sweep / f"{exp}_spp4"
        (d / ".hydra").mkdir(parents=True)
        (d / ".hydra" / "config.yaml").write_text(
            f"experiment: {exp}\nbudget: 4\nsweep_name: baselines\ndata:\n  name: tiny\n")
        (d / ".hydra" / "hydra.yaml").write_text(
            "hydra:\n  runtime:\n    choices:\n      capacity: cpu\n      train: plateau\n")
        (d / ".hydra" / "overrides.yaml").write_text(f"- +experiment={exp}\n")
        (d / "metrics.json").write_text(json.dumps(
            {"psnr": psnr, "ssim": 0.8, "rmse": 0.05, "flip": 0.1, "experiment": exp, "budget": 4,
             "commit": "abcdef1234567890", "train_steps": 30, "epochs": 3, "data_profile": "tiny"}))
    report_main([str(sweep), "--name", name, "--out", str(root / "reports"), "--bench", str(root / "no.csv"),
                 "--current", "current", "--note", f"What {name} is. More words."])
    return root / "reports" / name


def _readme(path: Path, body: str = f"{index.BEGIN}\nold\n{index.END}\n") -> Path:
    path.write_text(f"# Project\n\n## Results\n\n{body}\n## Documentation\n")
    return path


@pytest.mark.slow
def test_the_index_has_one_row_per_report_folder_and_marks_the_current_one(tmp_path):
    _readme(tmp_path / "README.md")
    _report(tmp_path, "older", 25.0)
    current = _report(tmp_path, "current", 28.0)
    bench = tmp_path / "reports" / "bench"
    bench.mkdir()
    (bench / "README.md").write_text("# Inference speed (python -m mcd.bench)\n\nrows\n")
    (tmp_path / "reports" / "scratch").mkdir()
    (current / "viewer").mkdir()
    (current / "viewer" / "index.html").write_text("<html></html>")  # where mcd.reporting.viewer writes it
    index.write_index(tmp_path / "reports", "current")
    text = (tmp_path / "reports" / "README.md").read_text()
    rows = {line.split(" | ")[0].lstrip("| "): line.split(" | ") for line in text.splitlines()
            if line.startswith("| ") and not line.startswith("| report")}
    assert list(rows) == ["**current** (current)", "bench", "older", "scratch"]  # current first
    row = rows["**current** (current)"]
    assert row[1] == "What current is." and row[2] == "tiny" and row[3] == "cpu" and row[4] == "abcdef1"
    assert row[5].startswith("2 trained runs") and "optimiser steps 30" in row[5]
    assert "[README](current/README.md)" in row[7] and "[viewer](current/viewer/index.html)" in row[7]
    assert rows["older"][1] == "What older is." and "viewer" not in rows["older"][7]
    assert rows["bench"][1] == "Inference speed (python -m mcd.bench)"
    assert rows["scratch"][1] == "no README.md"
    assert "The current report is `current`" in text


@pytest.mark.slow
def test_the_results_block_comes_from_the_current_report_and_regenerates_to_the_same_text(tmp_path):
    readme = _readme(tmp_path / "README.md")
    current = _report(tmp_path, "current", 28.0)  # the current report: README.md's block is written
    text = readme.read_text()
    block = text[text.index(index.BEGIN):text.index(index.END)]
    t1 = pd.read_csv(current / "table1.csv").set_index("experiment")
    assert "Ours (F)" in block and "[`current`](reports/current/README.md)" in block
    f = t1.loc["F"]
    assert f"{f['PSNR']:.2f} · {f['SSIM']:.2f} · {f['rMSE']:.2f} · {f['FLIP']:.2f}" in block
    assert not math.isnan(f["rMSE"]) and "old" not in block
    assert text.startswith("# Project\n\n## Results\n\n")
    assert text.endswith(f"{index.END}\n\n## Documentation\n")
    # regeneration: nothing changes, the file is not rewritten
    assert index.update_readme(readme, index.results_block(current, tmp_path)) is False
    report_main(["--index", "--out", str(tmp_path / "reports"), "--current", "current"])
    assert readme.read_text() == text
    # a report that is not the current one leaves README.md alone
    _report(tmp_path, "other", 20.0)
    assert readme.read_text() == text


@pytest.mark.parametrize("body", ["no markers here\n", f"{index.END}\n{index.BEGIN}\n",
                                  f"{index.BEGIN}\n{index.BEGIN}\n{index.END}\n"])
def test_a_readme_without_its_markers_is_refused_before_the_report_and_is_left_as_it_was(tmp_path, body):
    readme = _readme(tmp_path / "README.md", body)
    before = readme.read_text()
    with pytest.raises(SystemExit, match="results:begin"):
        _report(tmp_path, "current", 28.0)
    assert readme.read_text() == before
    assert not (tmp_path / "reports").exists()  # refused before any work
    with pytest.raises(ValueError, match=str(readme)):
        index.update_readme(readme, "anything")
    with pytest.raises(SystemExit, match="README.md does not exist"):
        report_main(["--index", "--out", str(tmp_path / "r"), "--readme", str(tmp_path / "x/README.md")])


def test_the_repository_readme_and_index_are_as_generated():
    """README.md's results and reports/README.md are what the generator writes from reports/ today: nobody
    typed them, and a report folder added without regenerating is caught. README.md stays within 100 lines."""
    readme = REPO / "README.md"
    text = readme.read_text()
    start, stop = text.index(index.BEGIN), text.index(index.END) + len(index.END)
    regenerate = "stale: regenerate with python -m mcd.report --index and commit the result"
    assert text[start:stop] == index.results_block(REPO / "reports" / index.CURRENT_REPORT, REPO), regenerate
    assert (REPO / "reports" / index.INDEX).read_text() == index.index_text(REPO / "reports"), regenerate
    assert len(text.splitlines()) <= 100

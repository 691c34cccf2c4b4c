"""Campaign 11, part 2 (notes/reliability_campaigns.md): ``mcd.report``'s record folders and its messages.

- Two sweeps from different places whose last two path parts agree (``x/ablation/tiny`` with rows A and F,
  ``y/ablation/tiny`` with one more A) kept one ``runs/ablation/tiny/multirun.yaml``: the second replaced the
  first without a word, and the report regenerated from ``runs/`` gave one sweep command, the first's, for the
  runs of both (a medium: provenance lost). Refused now before anything is written
  (``mcd.reporting.records.sweep_keys``), one ``error:`` line; two runs that would share a record folder,
  which ended in a ValueError traceback, are one ``error:`` line too.
- A second report into a folder that a first one is writing (its tables there, no README yet) was refused with
  the advice to delete that folder, the first report's (left by campaign 10): it says now that another report
  is writing it.
- ``--readme /dev/zero`` (or a FIFO) was "does not exist", and a README.md that is not UTF-8 gave the codec's
  message without the file (left by campaign 10): each is named as what it is.
- A ``--bench`` CSV whose ``ms_median`` is ``-5`` gave a ``speed_bench.csv`` whose fastest path took -5 ms: a
  latency that is not a positive finite number is refused before anything is written.

Real runs of the session's ``ab_sweep`` (rows A and F, 2 steps)."""

from __future__ import annotations

import csv
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from mcd.core.file_lock import exclusive_folder
from tests.conftest import module_env, report_in_worker
from tests.test_run import REPO


def _report(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess:
    """``python -m mcd.report <args>``, in this process (:func:`tests.conftest.report_in_worker`)."""
    return report_in_worker(list(args), cwd)


def _report_process(*args: str, cwd: Path = REPO) -> subprocess.CompletedProcess:
    """The same command in a fresh interpreter: for a lock that another process holds, and for a file the
    command must not read (a FIFO, a device), where a regression would wait until the timeout."""
    return subprocess.run([sys.executable, "-m", "mcd.report", *args], capture_output=True, text=True,
                          cwd=cwd, env=module_env(), timeout=600)


def _sweeps(ab_sweep: Path, tmp_path: Path) -> tuple[Path, Path]:
    """The session's sweep copied to ``x/ablation/tiny``, and its row A alone to ``y/ablation/tiny``."""
    x = tmp_path / "x" / "ablation" / "tiny"
    shutil.copytree(ab_sweep / "multirun" / "ablation" / "tiny", x)
    y = tmp_path / "y" / "ablation" / "tiny"
    y.mkdir(parents=True)
    shutil.copytree(x / "A_spp4", y / "A_again")
    text = (x / "multirun.yaml").read_text()
    assert "+experiment=A,F" in text
    (y / "multirun.yaml").write_text(text.replace("+experiment=A,F", "+experiment=A"))
    return x, y


@pytest.mark.slow
def test_two_sweeps_that_would_share_a_record_folder_are_refused_before_writing(ab_sweep, tmp_path):
    x, y = _sweeps(ab_sweep, tmp_path)
    proc = _report(str(x), str(y), "--out", str(tmp_path / "reports"), "--name", "two", "--no-viewer")
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "sweeps from different places would share the record folder(s) ablation/tiny" in proc.stderr
    assert "Traceback" not in proc.stderr and not (tmp_path / "reports").exists()
    # each alone keeps its own command
    assert _report(str(y), "--out", str(tmp_path / "reports"), "--name", "y", "--no-viewer").returncode == 0
    kept = tmp_path / "reports" / "y" / "runs" / "ablation" / "tiny" / "multirun.yaml"
    assert "- +experiment=A\n" in kept.read_text()


def test_two_runs_that_would_share_a_record_folder_are_one_error_line(ab_sweep, tmp_path):
    for where in ("k1", "k2"):
        shutil.copytree(ab_sweep / "multirun" / "ablation" / "tiny" / "A_spp4",
                        tmp_path / where / "a" / "b" / "A")
    proc = _report(str(tmp_path / "k1"), str(tmp_path / "k2"), "--out", str(tmp_path / "reports"),
                   "--name", "k")
    assert proc.returncode == 1 and "Traceback" not in proc.stderr, proc.stderr[-3000:]
    assert "runs from different places would share the record folder(s) a/b/A" in proc.stderr


@pytest.mark.slow
def test_a_report_being_written_is_named_as_such_not_as_a_folder_to_delete(ab_sweep, tmp_path):
    out = tmp_path / "reports"
    (out / "x").mkdir(parents=True)
    (out / "x" / "table1.csv").write_text("method\n")  # what the first report has written so far
    with exclusive_folder(out / "x") as held:  # what the first report holds while it writes
        assert held
        proc = _report_process(str(ab_sweep / "multirun" / "ablation" / "tiny"), "--out", str(out),
                               "--name", "x", "--no-viewer")
    assert proc.returncode == 1, proc.stderr[-3000:]
    assert "another mcd.report is writing this report now" in proc.stderr, proc.stderr
    assert "delete its folder" not in proc.stderr
    assert sorted(p.name for p in (out / "x").iterdir()) == ["table1.csv"]


@pytest.mark.parametrize("kind", ["device", "fifo", "not_utf8"])
def test_a_readme_that_is_no_text_file_is_named_as_what_it_is(tmp_path, kind):
    import os

    readme = {"device": Path("/dev/zero"), "fifo": tmp_path / "README.md",
              "not_utf8": tmp_path / "README.md"}[kind]
    if kind == "fifo":
        os.mkfifo(readme)
    elif kind == "not_utf8":
        readme.write_bytes(b"\xff\xfe not text")
    proc = _report_process("--index", "--out", str(tmp_path / "reports"), "--readme", str(readme))
    assert proc.returncode == 1, proc.stderr
    why = "is not UTF-8 text" if kind == "not_utf8" else "is not a regular file"
    assert f"{readme} {why}" in proc.stderr, proc.stderr
    assert not (tmp_path / "reports").exists()


def test_a_bench_csv_with_a_latency_no_bench_measures_is_refused(ab_sweep, tmp_path):
    bench = tmp_path / "bench.csv"
    columns = ["method", "device", "height", "width", "ms_median", "status"]
    with open(bench, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        w.writerow(["unet", "cpu", 32, 32, -5, "ok"])
        w.writerow(["F", "cpu", 32, 32, 40.0, "ok"])
    proc = _report(str(ab_sweep / "multirun" / "ablation" / "tiny"), "--out", str(tmp_path / "reports"),
                   "--bench", str(bench), "--no-viewer")
    assert proc.returncode == 1, proc.stderr[-3000:]
    assert f"--bench {bench}: an ms_median that is not a positive finite number" in proc.stderr
    assert not (tmp_path / "reports").exists()


@pytest.mark.slow
def test_a_frames_csv_giving_a_frame_twice_fails_that_run(ab_sweep, tmp_path):
    """A ``frames.csv`` whose last row is given twice was reported, the copy a second point of the per-frame
    table and plot, exit 0 (a low: no run writes one twice; a resumed run drops what it logged past its
    checkpoint). The run is failed now, named with the file (``mcd.reporting.runs.frames_problem``)."""
    sweep = tmp_path / "ablation" / "tiny"
    shutil.copytree(ab_sweep / "multirun" / "ablation" / "tiny", sweep)
    frames = sweep / "A_spp4" / "frames.csv"
    frames.write_text(frames.read_text() + frames.read_text().splitlines()[-1] + "\n")
    proc = _report(str(sweep), "--out", str(tmp_path / "reports"), "--no-viewer")
    assert proc.returncode == 1, proc.stderr[-3000:]
    assert f"{frames} is corrupt (cbox frame" in proc.stderr and "is given twice" in proc.stderr, proc.stderr


def test_a_scaling_finding_names_the_runs_that_stopped_before_its_budget(ab_sweep, tmp_path):
    """``--kind scaling`` of runs stopped by ``train.epochs=1`` after 1 step stated "tiny, 1500 steps: Ours
    (F) - A = +4.94 dB ...; Ours (F) above A holds" at their ``train.max_steps``, only the cells table saying
    that they stopped early (a medium: a finding at a budget its runs did not train). The finding names them
    now (``mcd.reporting.scaling.gaps.stopped_early``)."""
    proc = _report(str(ab_sweep / "multirun" / "ablation" / "tiny"), "--out", str(tmp_path / "reports"),
                   "--kind", "scaling", "--no-viewer")
    assert proc.returncode == 0, proc.stderr[-3000:]
    lines = (tmp_path / "reports" / "scaling" / "README.md").read_text().splitlines()
    (finding,) = [line for line in lines if line.startswith("- tiny, ") and " - A = " in line]
    assert "stopped early: Ours (F) seed 0 at step" in finding and "A seed 0 at step" in finding, finding

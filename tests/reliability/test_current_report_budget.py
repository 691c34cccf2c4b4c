"""``scripts/current_report.sh`` keeps one training budget per report (docs/reliability.md, "Campaign fixes"):
its mark file held the commit only, so a later session with another ``BUDGET_STEPS`` went ahead (a sweep skips
the finished jobs, which do not count the budget as part of the job, and trains the others to the new one),
and the report stage's note stated the last session's budget for every job. The first stage now records the
budget beside the commit; a training or report stage with another one is refused before any job runs."""

from __future__ import annotations

import subprocess

import pytest

from tests.reports.test_current_report import REPO, _job, _script


def _code() -> str:
    """What the script records as the code: the commit, and +dirty with uncommitted changes under mcd/."""
    head = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, check=True,
                          cwd=REPO).stdout.strip()
    dirty = subprocess.run(["git", "diff", "--quiet", "HEAD", "--", "mcd"], cwd=REPO).returncode
    return head + ("+dirty" if dirty else "")


def test_a_session_with_another_budget_is_refused_before_any_job(tmp_path):
    mark = tmp_path / "multirun" / "tiny_current.commit"
    mark.parent.mkdir()
    mark.write_text(f"{_code()} train.max_steps=1000\n")
    before = mark.read_bytes()
    proc = _script(tmp_path, "seeds", BUDGET_STEPS="3000")
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert "train.max_steps=1000" in proc.stderr and "BUDGET_STEPS=3000" in proc.stderr
    assert str(mark) in proc.stderr
    assert not (tmp_path / "multirun" / "seeds").exists()  # nothing ran
    assert mark.read_bytes() == before


@pytest.mark.slow
def test_the_report_stage_refuses_another_budget_and_states_the_recorded_one(tmp_path):
    root = tmp_path / "multirun"
    _job(root / "ablation" / "tiny_current", "F", 21.0)
    mark = root / "tiny_current.commit"
    mark.write_text("0123456789abcdef train.max_steps=3000\n")  # the report stage never checks the code
    proc = _script(tmp_path, "report")  # BUDGET_STEPS unset: 1000
    assert proc.returncode == 2 and "train.max_steps=3000" in proc.stderr, proc.stderr[-3000:]
    assert not (tmp_path / "reports").exists()
    proc = _script(tmp_path, "report", BUDGET_STEPS="3000")
    assert proc.returncode == 0, proc.stderr[-3000:]
    readme = (tmp_path / "reports" / "tiny_current" / "README.md").read_text()
    assert "train.max_steps=3000" in readme and "at commit 0123456789abcdef," in readme

"""``mcd.report --out`` never replaces a file it did not write, nor writes into the runs it reads
(``mcd.report.check_out``, docs/reliability.md, "Campaign fixes"): ``--out thesis`` replaced a user's own
``thesis/README.md`` with the reports index, and ``--out <sweep> --name <job>`` wrote the report into that
finished run directory, whose ``runs/`` copies then made every later report of the sweep refuse. Each is now
refused with one ``error:`` line before anything is written; a report regenerated from its own ``runs/``
into its own folder still works."""

from __future__ import annotations

import shutil

import pytest

from mcd.report import main
from tests.reliability.denoise_helpers import snapshot
from tests.reliability.test_report_paths import real_run  # noqa: F401  (a fixture)


def _report(*argv: str) -> int | str | None:
    try:
        main([*argv, "--no-viewer"])
    except SystemExit as stop:
        return stop.code
    return None


def test_a_users_readme_at_the_output_root_is_refused_and_kept(real_run, tmp_path):  # noqa: F811
    sweep = tmp_path / "multirun" / "sw"
    shutil.copytree(real_run, sweep / "unet")
    thesis = tmp_path / "thesis"
    thesis.mkdir()
    (thesis / "README.md").write_text("# My thesis notes\n")
    (thesis / "tiny").mkdir()
    (thesis / "tiny" / "README.md").write_text("# chapter 3\n")
    before = snapshot(thesis)
    code = _report(str(sweep), "--out", str(thesis), "--bench", str(tmp_path / "none"))
    assert isinstance(code, str)
    assert code.startswith(f"error: {thesis / 'README.md'}: not written by mcd.report")
    assert snapshot(thesis) == before
    (thesis / "README.md").unlink()  # the index may go there now; the report folder's own README still not
    code = _report(str(sweep), "--out", str(thesis), "--bench", str(tmp_path / "none"))
    assert isinstance(code, str) and f"{thesis / 'tiny' / 'README.md'}: not written by mcd.report" in code
    assert (thesis / "tiny" / "README.md").read_text() == "# chapter 3\n"


@pytest.mark.slow
def test_a_report_into_a_run_or_sweep_it_reads_is_refused_and_a_regenerated_one_is_not(real_run,  # noqa: F811
                                                                                       tmp_path):
    sweep = tmp_path / "multirun" / "sw"
    shutil.copytree(real_run, sweep / "unet")
    before = snapshot(tmp_path / "multirun")
    bench = ["--bench", str(tmp_path / "none")]
    for out, name in ((sweep, "unet"), (sweep.parent, "sw"), (sweep / "unet", "x")):
        code = _report(str(sweep), "--out", str(out), "--name", name, *bench)
        assert isinstance(code, str) and "a folder of runs the report reads" in code, (out, name, code)
    assert snapshot(tmp_path / "multirun") == before
    reports = tmp_path / "reports"
    assert _report(str(sweep), "--out", str(reports), "--name", "r", *bench) is None
    assert _report(str(reports / "r" / "runs"), "--out", str(reports), "--name", "r", *bench) is None
    assert (reports / "r" / "table1.csv").is_file() and snapshot(tmp_path / "multirun") == before


def test_an_output_folder_that_is_a_file_is_named(real_run, tmp_path):  # noqa: F811
    sweep = tmp_path / "multirun" / "sw"
    shutil.copytree(real_run, sweep / "unet")
    (tmp_path / "notdir").write_text("x")
    (tmp_path / "reports").mkdir()
    (tmp_path / "reports" / "foo").write_text("x")
    bench = ["--bench", str(tmp_path / "none")]
    code = _report(str(sweep), "--out", str(tmp_path / "notdir"), *bench)
    assert isinstance(code, str) and f"error: --out {tmp_path / 'notdir'} is a file, not a folder" in code
    code = _report(str(sweep), "--out", str(tmp_path / "reports"), "--name", "foo", *bench)
    assert isinstance(code, str) and f"the report folder {tmp_path / 'reports' / 'foo'} is a file" in code
    assert (tmp_path / "notdir").read_text() == "x"
    assert sorted(p.name for p in (tmp_path / "reports").iterdir()) == ["foo"]

"""A report never writes or deletes outside its output root (``mcd.report.report_name``,
``mcd.core.paths.check_folder_name``): with no ``--name`` the report is named after the runs' data profile,
read
from ``metrics.json``; a ``"data_profile"`` of ``"../../escaped"`` or an absolute folder made ``mcd.report``
write its report there, overwriting a ``README.md`` and deleting a ``runs/thesis.tex`` it found; a ``--name``
holding ``/`` or ``..`` did the same. Such a name is refused, naming the field and the file (or ``--name``),
before anything is written."""

from __future__ import annotations

import json
import shutil

import pytest

from mcd.report import main
from tests.reliability.denoise_helpers import snapshot


@pytest.fixture
def real_run(unet_run):
    """A run directory that ``mcd.run`` finished (``+experiment=unet capacity=cpu``, the 32x32 store): the
    session's ``unet_run``, which each test copies before changing."""
    return unet_run[0]


def _victims(root):
    """Files a report steered outside its root would overwrite (README.md) or delete (runs/thesis.tex)."""
    (root / "runs").mkdir(parents=True)
    (root / "README.md").write_text("my notes\n")
    (root / "runs" / "thesis.tex").write_text("\\chapter{}\n")
    return snapshot(root)


def _report(tmp_path, sweep, *extra):
    out = tmp_path / "a" / "b" / "reports"
    try:
        main([str(sweep), "--out", str(out), "--bench", str(tmp_path / "none"), "--no-viewer", *extra])
    except SystemExit as stop:
        return out, stop.code
    return out, None


@pytest.mark.parametrize("profile", ["../../escaped", "ABS"])
def test_a_data_profile_that_leaves_the_output_root_is_refused_naming_the_field_and_file(real_run, tmp_path,
                                                                                        profile):
    target = tmp_path / "a" / "escaped" if profile != "ABS" else tmp_path / "abs" / "dir"
    before = _victims(target)
    sweep = tmp_path / "multirun"
    shutil.copytree(real_run, sweep / "0")
    metrics = sweep / "0" / "metrics.json"
    record = json.loads(metrics.read_text())
    record["data_profile"] = str(target) if profile == "ABS" else profile
    metrics.write_text(json.dumps(record))
    out, code = _report(tmp_path, sweep)
    assert snapshot(target) == before  # README.md not overwritten, runs/thesis.tex not deleted
    assert not out.exists()  # nothing written
    named = f"error: data_profile in {metrics.resolve()}={record['data_profile']!r}: not a plain folder name"
    assert isinstance(code, str) and code.startswith(named), code
    assert "give --name" in code


@pytest.mark.parametrize("name", ["../../escaped", "x/../../../escaped", "..", ".hidden", "a/b"])
def test_a_name_with_a_slash_or_dots_is_refused(real_run, tmp_path, name):
    before = _victims(tmp_path / "a" / "escaped")
    sweep = tmp_path / "multirun"
    shutil.copytree(real_run, sweep / "0")
    out, code = _report(tmp_path, sweep, "--name", name)
    assert snapshot(tmp_path / "a" / "escaped") == before
    assert not out.exists() and not (tmp_path / "a" / "b" / "escaped").exists()
    assert code == f"error: --name={name!r}: not a plain folder name (letters, digits, '_', '-', '.', not " \
                   "leading '.'); the report is written to <out>/<name>/, so a name must not hold '/' or '..'"


@pytest.mark.slow
def test_a_plain_profile_still_names_the_report(real_run, tmp_path):
    sweep = tmp_path / "multirun"
    shutil.copytree(real_run, sweep / "0")
    out = tmp_path / "reports"
    main([str(sweep), "--out", str(out), "--bench", str(tmp_path / "none"), "--no-viewer"])
    assert (out / "tiny" / "README.md").is_file()  # the data group chosen: data=tiny

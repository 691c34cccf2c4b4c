"""``python -m mcd.bundle`` never writes over a bundle it was not asked to replace (docs/reliability.md,
"Campaign fixes"): ``--name unet-cpu-small`` replaced the shipped bundle's ``.pt`` and ``.json`` with a 2-step
run's, exit 0, without a word. A bundle of the name in ``--out`` is now refused with one ``error:`` line (exit
2) and keeps its bytes; ``--replace`` writes over it; a bad ``--name`` or a run without ``metrics.json`` is
one ``error:`` line, not a traceback."""

from __future__ import annotations

import shutil
import subprocess
import sys

import pytest

from mcd.denoise.weights import BUNDLED_DIR
from tests.conftest import REPO
from tests.reliability.denoise_helpers import snapshot


def _bundle(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "mcd.bundle", *args], capture_output=True, text=True,
                          cwd=REPO, timeout=600)


@pytest.fixture(scope="module")
def finished(unet_run):
    """A run directory of ``+experiment=unet`` that ``mcd.run`` finished: the session's ``unet_run``
    (tests/conftest.py), which ``mcd.bundle`` only reads (the unfinished run below is a copy)."""
    return unet_run[0]


@pytest.mark.slow
def test_a_shipped_bundles_name_is_refused_and_kept_unless_replace(finished, tmp_path):
    out = tmp_path / "bundled"
    out.mkdir()
    for suffix in (".pt", ".json"):  # the shipped bundle, as an installed package holds it
        shutil.copy(BUNDLED_DIR / f"unet-cpu-small{suffix}", out)
    before = snapshot(out)
    proc = _bundle(str(finished), "--name", "unet-cpu-small", "--out", str(out))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.startswith("error: ") and "Traceback" not in proc.stderr
    assert "unet-cpu-small.pt" in proc.stderr and "--replace" in proc.stderr
    assert snapshot(out) == before  # every byte kept, nothing added

    proc = _bundle(str(finished), "--name", "unet-cpu-small", "--out", str(out), "--replace")
    assert proc.returncode == 0, proc.stderr[-3000:]
    after = snapshot(out)
    assert sorted(after) == sorted(before)  # the two files, no temp file left
    assert after["unet-cpu-small.pt"] != before["unet-cpu-small.pt"]

    proc = _bundle(str(finished), "--name", "fresh", "--out", str(out))  # a new name needs no flag
    assert proc.returncode == 0 and (out / "fresh.pt").is_file(), proc.stderr[-3000:]


@pytest.mark.slow
def test_a_bad_name_or_an_unfinished_run_is_one_error_line(finished, tmp_path):
    out = tmp_path / "bundled"
    proc = _bundle(str(finished), "--name", "../escaped", "--out", str(out))
    assert proc.returncode == 2 and proc.stderr.startswith("error: --name='../escaped'"), proc.stderr
    assert "Traceback" not in proc.stderr and not out.exists() and not (tmp_path / "escaped.pt").exists()
    unfinished = tmp_path / "unfinished"
    shutil.copytree(finished, unfinished)
    (unfinished / "metrics.json").unlink()  # a run stopped before its test
    proc = _bundle(str(unfinished), "--name", "x", "--out", str(out))
    assert proc.returncode == 2 and "metrics.json: missing" in proc.stderr, proc.stderr
    assert "Traceback" not in proc.stderr and not out.exists()

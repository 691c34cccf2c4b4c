"""Campaign 9, part 2 (notes/reliability_campaigns.md): ``python -m mcd.bench train`` that measures nothing.
An unknown ``--profiles``, ``--methods`` or ``--paths`` started every job, each failed (or was skipped), and
the command then replaced ``--out`` (an earlier measurement) with an empty table, exit 0 (campaign 8 fixed
the same for ``speed``). Now the names are checked before any job (exit 2 naming the flag and what is
valid), and a run in which no path was measured leaves ``--out`` as it was, exit 1. The command runs for
real."""

from __future__ import annotations

import subprocess

import pytest

from tests.conftest import command_in_worker, module_env

EARLIER = "method,profile\nearlier,measurement\n"


def _train(tmp_path, *args: str) -> subprocess.CompletedProcess:
    """``python -m mcd.bench train``, in this process (:func:`tests.conftest.command_in_worker`)."""
    argv = ["train", "--steps", "1", "--warmup", "0", "--threads", "1", "--out", str(tmp_path / "train.csv"),
            *args, f"paths.data_dir={tmp_path / 'data'}"]
    return command_in_worker("mcd.bench", argv, tmp_path, module_env())


@pytest.mark.parametrize(("args", "named"), [
    (["--profiles", "nosuch", "--methods", "unet", "--paths", "fp32"], "--profiles 'nosuch': no nosuch"),
    (["--profiles", "tiny", "--methods", "nosuch", "--paths", "fp32"], "--methods 'nosuch': no nosuch"),
    (["--profiles", "tiny", "--methods", "unet", "--paths", "nosuch"], "--paths 'nosuch': no nosuch"),
    (["--profiles", "tiny", "--methods", "unet", "--paths", "fp32", "--profile-methods", "small"],
     "--profile-methods 'small': give PROFILE=M1,M2"),
])
@pytest.mark.slow
def test_unknown_names_are_refused_before_any_job_and_keep_the_csv(tmp_path, args, named):
    (tmp_path / "train.csv").write_text(EARLIER)
    proc = _train(tmp_path, *args)
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert named in proc.stderr and "Traceback" not in proc.stderr, proc.stderr
    assert (tmp_path / "train.csv").read_text() == EARLIER
    assert not (tmp_path / "data").exists()


@pytest.mark.slow
def test_a_run_whose_every_job_failed_keeps_the_csv(tmp_path):
    (tmp_path / "train.csv").write_text(EARLIER)
    proc = _train(tmp_path, "--profiles", "tiny", "--methods", "unet", "--paths", "fp32", "nosuch.key=1")
    assert proc.returncode == 1, proc.stderr[-3000:]
    assert "no path was measured (1 failed" in proc.stderr, proc.stderr[-3000:]
    assert (tmp_path / "train.csv").read_text() == EARLIER

"""Campaign 10, part 2 (notes/reliability_campaigns.md; left by campaign 9, part 2): ``python -m mcd.bundle``
took a run's last ``checkpoints/best*.ckpt`` by name, so a foreign ``best-step000099.ckpt`` (F's) copied into
row A's run made an F bundle whose provenance stated row A's metrics, exit 0; and a ``metrics.json`` that is
a JSON list ended in an AttributeError traceback. The run's own checkpoint (the one its ``metrics.json``
names) is bundled now, a run record of another shape is one ``error:`` line naming the file, and
``mcd-denoise --checkpoint <run dir>`` takes the same checkpoint. Real runs of the session's ``ab_sweep``."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from tests.conftest import REPO, command_in_worker, module_env


def _bundle(*args: str) -> subprocess.CompletedProcess:
    """``python -m mcd.bundle <args>``, in this process (:func:`tests.conftest.command_in_worker`)."""
    return command_in_worker("mcd.bundle", list(args), REPO, module_env())


def _runs(ab_sweep: Path, tmp_path: Path) -> tuple[Path, Path]:
    """A private copy of the sweep's row A run, and F's run (read only)."""
    jobs = ab_sweep / "multirun" / "ablation" / "tiny"
    run = tmp_path / "A_spp4"
    shutil.copytree(jobs / "A_spp4", run)
    return run, jobs / "F_spp4"


@pytest.mark.slow
def test_a_foreign_best_checkpoint_in_the_run_is_not_bundled(ab_sweep, tmp_path):
    run, f_run = _runs(ab_sweep, tmp_path)
    (f_best,) = (f_run / "checkpoints").glob("best*.ckpt")
    shutil.copy(f_best, run / "checkpoints" / "best-step000099.ckpt")  # sorts after the run's own
    proc = _bundle(str(run), "--name", "a", "--out", str(tmp_path / "out"))
    assert proc.returncode == 0, proc.stderr[-3000:]
    meta = json.loads((tmp_path / "out" / "a.json").read_text())
    assert meta["config"]["experiment"] == "A", "a foreign checkpoint was bundled under the run's metrics"
    assert meta["checkpoint"].startswith("checkpoints/best-step000001.ckpt")


def test_mcd_denoise_takes_the_runs_own_checkpoint_and_refuses_two_unrecorded(ab_sweep, tmp_path):
    from mcd.denoise.weights import tested_checkpoint

    run, f_run = _runs(ab_sweep, tmp_path)
    (f_best,) = (f_run / "checkpoints").glob("best*.ckpt")
    shutil.copy(f_best, run / "checkpoints" / "best-step000099.ckpt")
    assert tested_checkpoint(run, "--checkpoint") == run / "checkpoints" / "best-step000001.ckpt"
    (run / "metrics.json").unlink()
    with pytest.raises(FileNotFoundError, match="best-step000001.ckpt, best-step000099.ckpt"):
        tested_checkpoint(run, "--checkpoint")


def test_mcd_denoise_names_a_run_that_never_finished_and_takes_its_checkpoint_so_far(ab_sweep, tmp_path,
                                                                                      caplog):
    """``mcd-denoise --checkpoint <an interrupted run>`` (no ``metrics.json``) used its best checkpoint so far
    without a word that the run never finished or was tested (campaign 13, low); a warning names it now, and
    a finished run gets none."""
    import logging

    from mcd.denoise.weights import resolve

    run, _ = _runs(ab_sweep, tmp_path)
    with caplog.at_level(logging.WARNING, logger="mcd.denoise.weights"):
        resolve(str(run))
    assert "no metrics.json" not in caplog.text
    (run / "metrics.json").unlink()
    with caplog.at_level(logging.WARNING, logger="mcd.denoise.weights"):
        *_, source = resolve(str(run))
    assert source == str(run / "checkpoints" / "best-step000001.ckpt")
    assert f"--checkpoint={run}: the run has no metrics.json (it never finished" in caplog.text, caplog.text
    assert "best-step000001.ckpt is its checkpoint so far, untested" in caplog.text


def test_a_checkpoint_of_another_experiment_under_the_tested_name_is_refused(ab_sweep, tmp_path):
    run, f_run = _runs(ab_sweep, tmp_path)
    (f_best,) = (f_run / "checkpoints").glob("best*.ckpt")
    shutil.copy(f_best, run / "checkpoints" / "best-step000001.ckpt")  # F's bytes under A's tested name
    proc = _bundle(str(run), "--name", "a", "--out", str(tmp_path / "out"))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "experiment 'F'" in proc.stderr and "metrics.json" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "out" / "a.pt").exists()


@pytest.mark.parametrize(("file", "text", "named"), [
    ("metrics.json", "[1, 2]", "a list, not a JSON object"),
    ("metrics.json", "{not json", "not readable"),
    (".hydra/overrides.yaml", b"\xac\xed\x00\x05garbage", "not readable"),
])
def test_a_run_record_of_another_shape_is_one_error_line_naming_the_file(ab_sweep, tmp_path, file, text,
                                                                         named):
    run, _ = _runs(ab_sweep, tmp_path)
    path = run / file
    path.write_bytes(text) if isinstance(text, bytes) else path.write_text(text)
    proc = _bundle(str(run), "--name", "a", "--out", str(tmp_path / "out"))
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert proc.stderr.startswith(f"error: {path}: {named}"), proc.stderr
    assert "Traceback" not in proc.stderr and not (tmp_path / "out" / "a.pt").exists()


@pytest.mark.slow
def test_a_bundles_weights_replaced_by_another_bundles_are_refused(ab_sweep, tmp_path, capsys):
    """Two bundles of one model (row A's best and its last checkpoint): the second's ``.pt`` copied over the
    first's was denoised with, and ``denoise.json`` stated the first's training for it, exit 0."""
    from mcd.denoise.cli import run
    from tests.reliability.denoise_helpers import write_frames

    run_a, _ = _runs(ab_sweep, tmp_path)
    last = tmp_path / "A_last"
    shutil.copytree(run_a, last)
    record = json.loads((last / "metrics.json").read_text())
    (last / "metrics.json").write_text(json.dumps({**record, "checkpoint": "checkpoints/last.ckpt"}))
    out = tmp_path / "out"
    for run_dir, name in ((run_a, "a1"), (last, "a2")):
        proc = _bundle(str(run_dir), "--name", name, "--out", str(out))
        assert proc.returncode == 0, proc.stderr[-3000:]
    assert (out / "a1.pt").read_bytes() != (out / "a2.pt").read_bytes()
    write_frames(tmp_path / "frames", n=2, size=(32, 32))
    run([str(tmp_path / "frames"), "-o", str(tmp_path / "ok"), "--checkpoint", str(out / "a1.pt"),
         "--no-progress"])
    shutil.copy(out / "a2.pt", out / "a1.pt")
    with pytest.raises(SystemExit) as exc:
        run([str(tmp_path / "frames"), "-o", str(tmp_path / "swapped"), "--checkpoint", str(out / "a1.pt"),
             "--no-progress"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert f"{out / 'a1.pt'}: its SHA-256 is" in err and "a1.json was written for" in err, err
    assert not (tmp_path / "swapped" / "denoise.json").exists()


@pytest.mark.parametrize(("out", "named"), [
    ("afile", "--out={out} is a file, not a folder"),
    ("afile/sub", "--out={out} lies below"),
])
def test_an_out_that_cannot_be_a_folder_names_the_flag(ab_sweep, tmp_path, out, named):
    """``--out`` a file said ``error: [Errno 17] File exists: 'afile'``: no flag, no fix."""
    run, _ = _runs(ab_sweep, tmp_path)
    (tmp_path / "afile").write_text("a user's file")
    proc = _bundle(str(run), "--name", "a", "--out", str(tmp_path / out))
    assert proc.returncode == 2 and named.format(out=tmp_path / out) in proc.stderr, proc.stderr
    assert (tmp_path / "afile").read_text() == "a user's file"

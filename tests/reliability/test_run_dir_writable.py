"""Campaign 8 (docs/reliability.md): a ``hydra.run.dir`` that cannot be made or written is named before Hydra
makes it. ``mcd.run`` on a read-only mount, or below a file, ended in Hydra's own OSError / FileExistsError
traceback (campaigns 5 and 7 left it: Hydra makes the folder before any of our code runs); now the single
run's check before Hydra (``mcd.config.compose.check_run_dir``) gives one ``error:`` line naming the key,
exit 2, and nothing is made."""

from __future__ import annotations

import subprocess
import sys

from tests.conftest import module_env, store32_overrides


def _run(*overrides: str, cwd, wrap=None) -> subprocess.CompletedProcess:
    argv = [sys.executable, "-m", "mcd.run", "+experiment=unet", "train.max_steps=1", *overrides]
    if wrap is not None:
        argv = wrap(argv)
    return subprocess.run(argv, cwd=cwd, env=module_env(), capture_output=True, text=True, timeout=600)


def test_a_run_dir_below_a_file_is_one_error_line_naming_the_key(tmp_path):
    (tmp_path / "a_file").write_text("mine\n")
    proc = _run(*store32_overrides(tmp_path / "data"), f"hydra.run.dir={tmp_path / 'a_file' / 'run'}",
                cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr[-3000:]
    below = tmp_path / "a_file"
    assert f"error: hydra.run.dir={below / 'run'} lies below {below}, which is a file" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert (tmp_path / "a_file").read_text() == "mine\n" and not (tmp_path / "data").exists()


def test_a_read_only_run_dir_is_one_error_line_naming_the_key(tmp_path, read_only_dir):
    ro, read_only = read_only_dir
    for run_dir, words in ((ro, "is not writable"),
                           (ro / "run", f"would be made in {ro}, which is not writable")):
        proc = _run(*store32_overrides(tmp_path / "data"), f"hydra.run.dir={run_dir}", cwd=tmp_path,
                    wrap=read_only)
        assert proc.returncode == 2, proc.stderr[-3000:]
        assert f"error: hydra.run.dir={run_dir} {words}" in proc.stderr
        assert "Traceback" not in proc.stderr
    assert list(ro.iterdir()) == [] and not (tmp_path / "data").exists()

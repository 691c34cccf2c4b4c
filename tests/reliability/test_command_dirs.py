"""Campaign 11, part 1 (docs/reliability.md, "Campaign fixes"): a Hydra command other than ``mcd.run``
does not write into a user's folder given as ``hydra.run.dir``.

``python -m mcd.render`` (``mcd.plan``, ``mcd.pack``) with ``hydra.run.dir=<a folder of the user's>`` holding
their own ``render.log`` appended its log to that file, exit 0, and wrote ``.hydra/`` beside it (campaign 9
fixed the same for ``mcd.run``'s outputs only). Every Hydra command now checks its own names
(``mcd.config.compose.command_files``: ``<job>.log``, ``.hydra/``) before Hydra writes: one ``error:`` line
naming ``hydra.run.dir``, exit 2, the file kept; a command's own folder (it holds ``.hydra/``) is taken as
before.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from tests.conftest import module_env, store32_overrides


def _run(tmp_path, module: str, run_dir) -> subprocess.CompletedProcess:
    argv = [sys.executable, "-m", module, *store32_overrides(tmp_path / "data"), "plan.measure=false",
            f"hydra.run.dir={run_dir}"]
    return subprocess.run(argv, cwd=tmp_path, env=module_env(), capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("module", ["mcd.render", "mcd.plan", "mcd.pack"])
def test_a_users_log_named_like_the_commands_is_refused_and_kept(tmp_path, module):
    folder = tmp_path / "mine"
    folder.mkdir()
    log = folder / f"{module.split('.')[1]}.log"
    log.write_text("my notes\n")
    proc = _run(tmp_path, module, folder)
    assert proc.returncode == 2, (proc.stdout + proc.stderr)[-4000:]
    assert f"error: hydra.run.dir={folder} holds {log.name}, which a run writes" in proc.stderr
    assert log.read_text() == "my notes\n" and sorted(p.name for p in folder.iterdir()) == [log.name]
    assert not (tmp_path / "data").exists()


@pytest.mark.slow
def test_a_commands_own_folder_is_taken_again(tmp_path):
    own = tmp_path / "plan"
    for _ in range(2):
        proc = _run(tmp_path, "mcd.plan", own)
        assert proc.returncode == 0, (proc.stdout + proc.stderr)[-4000:]
    assert (own / ".hydra").is_dir() and (own / "plan.log").is_file()

"""Campaign 12, part 1 (docs/reliability.md, "Campaign fixes"): a sweep never replaces a user's file named
``multirun.yaml`` in its ``hydra.sweep.dir``.

``python -m mcd.run -m +experiment=noisy seed=0 hydra.sweep.dir=<a folder of the user's>`` whose
``multirun.yaml`` was the user's notes replaced it with the sweep's record, exit 0 (high: a user's file
lost). Now ``mcd.lit.sweep_dirs.check_sweep_record`` (the ``SweepDirs`` callback, before the sweeper writes
anything) refuses a ``multirun.yaml`` that is not a sweep's record, or a link, naming ``hydra.sweep.dir``,
exit 2, nothing written; a sweep run again into its own folder goes on (its record is Hydra's).
"""

from __future__ import annotations

import subprocess

import pytest

from tests.conftest import command_in_worker, module_env, store32_overrides


def _sweep(cwd, sweep_dir) -> subprocess.CompletedProcess:
    """The sweep, in this process (:func:`tests.conftest.command_in_worker`)."""
    argv = ["-m", *store32_overrides(cwd / "data"), "+experiment=noisy", "seed=0",
            "trainer.enable_progress_bar=false", f"hydra.sweep.dir={sweep_dir}"]
    return command_in_worker("mcd.run", argv, cwd, module_env())


@pytest.mark.slow
def test_a_users_multirun_yaml_is_not_replaced_by_a_sweep(tmp_path):
    notes, linked = tmp_path / "notes", tmp_path / "linked"
    notes.mkdir()
    linked.mkdir()
    (notes / "multirun.yaml").write_text("my notes\n")
    (tmp_path / "thesis.yaml").write_text("chapter 1\n")
    (linked / "multirun.yaml").symlink_to(tmp_path / "thesis.yaml")
    for folder, why in ((notes, "not a sweep's record"), (linked, "a symbolic link to")):
        proc = _sweep(tmp_path, folder)
        assert proc.returncode == 2, (proc.stdout + proc.stderr)[-4000:]
        assert f"error: hydra.sweep.dir={folder} holds multirun.yaml, {why}" in proc.stderr
        assert "Traceback" not in proc.stderr
        assert sorted(p.name for p in folder.iterdir()) == ["multirun.yaml"]  # nothing written
    assert (notes / "multirun.yaml").read_text() == "my notes\n"
    assert (tmp_path / "thesis.yaml").read_text() == "chapter 1\n"

    own = tmp_path / "own"
    for _ in range(2):  # a sweep, then the same sweep again into its own folder (skipped as finished)
        proc = _sweep(tmp_path, own)
        assert proc.returncode == 0, (proc.stdout + proc.stderr)[-4000:]
    assert "mode: MULTIRUN" in (own / "multirun.yaml").read_text() and "skip:" in proc.stdout + proc.stderr

"""Campaign 9 (docs/reliability.md): ``mcd.run`` never writes over a user's files in ``hydra.run.dir``.

``hydra.run.dir=<a folder of the user's>`` holding their own ``frames.csv``, ``curve.csv``,
``resolved_config.yaml`` and ``logs/metrics.csv`` (no run's records) trained, and replaced all four with the
run's, exit 0. Now a single run's directory that holds names a run writes (``mcd.run.RUN_OUTPUTS``) and none
of a run's records (``RUN_RECORDS``: ``.hydra/``, ``job.json``, ``run.lock``) is refused before Hydra writes
anything (``mcd.config.compose.check_unclaimed``): one ``error:`` line naming the key and the files, exit 2.
A run's own directory (finished, interrupted) holds its records and is taken as before.
"""

from __future__ import annotations

from tests.conftest import REPO, command_in_worker, module_env, store32_overrides


def test_a_users_folder_with_files_named_like_a_runs_is_refused_and_kept(tmp_path):
    folder = tmp_path / "thesis"
    (folder / "logs").mkdir(parents=True)
    mine = {"frames.csv": "my,data\n", "curve.csv": "step,loss\n", "resolved_config.yaml": "a: 1\n",
            "logs/metrics.csv": "x\n", "README.md": "# mine\n"}
    for name, text in mine.items():
        (folder / name).write_text(text)
    args = ["+experiment=unet", "capacity=cpu", *store32_overrides(tmp_path / "data"), "train.max_steps=1",
            "train.sample_frames=[]", f"hydra.run.dir={folder}"]
    proc = command_in_worker("mcd.run", args, REPO, module_env())
    assert proc.returncode == 2, proc.stderr[-3000:]
    assert "error: hydra.run.dir=" in proc.stderr and "frames.csv" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert {p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()} == set(mine)
    assert all((folder / name).read_text() == text for name, text in mine.items())
    assert not (tmp_path / "data").exists()

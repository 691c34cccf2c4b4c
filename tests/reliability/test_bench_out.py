"""``python -m mcd.bench --out <folder>/x.csv`` wrote its README.md beside the CSV over a user's own
``<folder>/README.md``. A README there that the bench did not write is now refused before anything is
measured, naming it, and stays as it was; the bench's own README is replaced as before
(``mcd.bench.speed.check_readme``, docs/reliability.md, "Campaign fixes")."""

from __future__ import annotations

import pytest

from mcd.bench import speed


def _bench(out) -> None:
    speed.main(["--methods", "noisy", "--sizes", "16x16", "--devices", "cpu", "--warmup", "0", "--reps", "1",
                "--synthetic", "--allocator", "system", "--out", str(out), "capacity=cpu"])


def test_a_users_readme_beside_the_csv_is_refused_and_kept(tmp_path, capsys):
    (tmp_path / "README.md").write_text("# My thesis notes\n")
    with pytest.raises(SystemExit) as stop:
        _bench(tmp_path / "bench.csv")
    assert stop.value.code == 2
    assert f"{tmp_path / 'README.md'} is not a README the bench wrote" in capsys.readouterr().err
    assert (tmp_path / "README.md").read_text() == "# My thesis notes\n"
    assert not (tmp_path / "bench.csv").exists()


@pytest.mark.slow
def test_the_benchs_own_readme_is_replaced(tmp_path):
    _bench(tmp_path / "bench.csv")
    first = (tmp_path / "README.md").read_text()
    assert first.startswith(speed.README_TITLE + "\n")
    _bench(tmp_path / "bench.csv")
    assert (tmp_path / "README.md").read_text().startswith(speed.README_TITLE + "\n")


@pytest.mark.slow
def test_a_users_file_named_as_out_is_refused_and_kept(tmp_path, capsys):
    """Campaign 13: ``--out <folder>/mine.csv``, a user's own file (``mine,1``), was replaced by the bench's
    CSV, exit 0 (``mcd.bench.speed.check_csv``); a bench CSV there is replaced as before."""
    mine = tmp_path / "mine.csv"
    mine.write_text("mine,1\n")
    with pytest.raises(SystemExit) as stop:
        _bench(mine)
    assert stop.value.code == 2
    assert f"--out {mine}: exists and is not a CSV the bench wrote" in capsys.readouterr().err
    assert mine.read_text() == "mine,1\n" and not (tmp_path / "README.md").exists()
    _bench(tmp_path / "bench.csv")
    _bench(tmp_path / "bench.csv")  # its own CSV again
    assert (tmp_path / "bench.csv").read_text().startswith("method,device,")

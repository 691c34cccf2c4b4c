"""Campaign 12, part 2 (notes/reliability_campaigns.md): ``python -m mcd.bench loader --dir <a file>`` ended
in a ValueError traceback naming ``data.train_store.dir``, a key of the config the bench makes, not the flag
the user gave. ``--dir`` is checked by the parser now (``mcd.core.paths.writable_folder_arg``): exit 2 naming
``--dir``, before anything is measured or written."""

from __future__ import annotations

import pytest

from mcd.bench.loader import main


@pytest.mark.parametrize("below", [False, True])
def test_a_dir_that_is_a_file_is_the_parsers_error_naming_the_flag(tmp_path, capsys, below):
    user = tmp_path / "notes.txt"
    user.write_text("mine")
    with pytest.raises(SystemExit) as exc:
        main(["--dir", str(user / "x" if below else user), "--width", "16", "--height", "16"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "argument --dir" in err and str(user) in err and "is a file" in err, err
    assert "Traceback" not in err and "data.train_store.dir" not in err
    assert user.read_text() == "mine" and sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]

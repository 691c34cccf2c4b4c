"""mcd/core/atomic_write.py: the one atomic write of the stores, the run directory and ``mcd-denoise``'s
outputs. Real files and real processes: a writer that raises or is killed half-way, a symlink at the final
name, writers racing on one path while a reader watches it."""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from mcd.core.atomic_write import atomic_write, atomic_write_json, leftovers

ROOT = Path(__file__).resolve().parents[2]


def _python(code: str, *args: str) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(code), *args], env=env)


def _hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.mark.parametrize("error", [OSError("disk full"), KeyboardInterrupt("killed while writing")])
@pytest.mark.parametrize("existing", [True, False])
def test_a_writer_that_raises_half_way_leaves_the_old_file_or_none_and_no_temp(tmp_path, error, existing):
    path = tmp_path / "metrics.json"
    if existing:
        path.write_text("old whole file")

    def half(tmp: Path) -> None:
        tmp.write_text('{"psnr": 3')  # half the bytes are on disk when it stops
        raise error

    with pytest.raises(type(error)):
        atomic_write(path, half)
    assert (path.read_text() == "old whole file") if existing else not path.exists()
    assert _hidden(tmp_path) == [] and leftovers(path) == []


def test_a_killed_writer_leaves_the_old_file_whole_and_its_temp_among_the_leftovers(tmp_path):
    path = tmp_path / "frame.exr"
    path.write_bytes(b"old" * 1000)
    killed = _python("""
        import os, signal, sys
        from pathlib import Path
        from mcd.core.atomic_write import atomic_write

        def half(tmp):
            tmp.write_bytes(b"new" * 500)
            os.kill(os.getpid(), signal.SIGKILL)

        atomic_write(Path(sys.argv[1]), half)
    """, str(path))
    assert killed.wait(timeout=60) == -9
    assert path.read_bytes() == b"old" * 1000
    [temp] = leftovers(path)
    assert temp.read_bytes() == b"new" * 500 and temp.name.startswith(".frame.exr.") and temp.suffix == ".exr"
    assert leftovers(tmp_path / "frame.ex") == [] and leftovers(tmp_path / "rame.exr") == []


def test_the_writer_gets_an_empty_hidden_file_beside_the_final_name_with_its_suffix(tmp_path):
    path = tmp_path / "made" / "below" / "f0000.png"  # missing folders are made
    seen: list[Path] = []

    def write(tmp: Path) -> None:
        seen.append(tmp)
        assert tmp.read_bytes() == b""
        tmp.write_bytes(b"png")

    atomic_write(path, write)
    [tmp] = seen
    assert tmp.parent == path.parent and tmp.name.startswith(".f0000.png.") and tmp.suffix == ".png"
    assert path.read_bytes() == b"png" and _hidden(path.parent) == []


def test_a_symlink_at_the_final_name_is_replaced_and_its_target_untouched(tmp_path):
    victim = tmp_path / "precious.txt"
    victim.write_text("keep me")
    path = tmp_path / "out" / "denoise.json"
    path.parent.mkdir()
    path.symlink_to(victim)
    atomic_write_json(path, {"complete": True})
    assert victim.read_text() == "keep me"
    assert not path.is_symlink() and json.loads(path.read_text()) == {"complete": True}


@pytest.mark.parametrize(("umask", "mode"), [(0o022, 0o644), (0o027, 0o640)])
def test_the_file_gets_the_umasks_mode_also_over_a_private_one(tmp_path, umask, mode):
    path = tmp_path / "manifest.json"
    path.write_text("{}")
    path.chmod(0o600)
    old = os.umask(umask)
    try:
        atomic_write_json(path, {"files": {}})
    finally:
        os.umask(old)
    assert stat.S_IMODE(path.stat().st_mode) == mode


def test_json_is_indented_ends_with_a_newline_and_an_unserialisable_value_keeps_the_old_file(tmp_path):
    path = tmp_path / "job.json"
    atomic_write_json(path, {"budget": 4, "where": tmp_path}, indent=2, default=str)
    assert path.read_text() == json.dumps({"budget": 4, "where": str(tmp_path)}, indent=2) + "\n"
    with pytest.raises(TypeError, match="not JSON serializable"):
        atomic_write_json(path, {"where": tmp_path})
    assert json.loads(path.read_text())["budget"] == 4 and _hidden(tmp_path) == []


def test_concurrent_writers_leave_one_whole_file_and_a_reader_never_sees_part_of_one(tmp_path):
    """Four processes each write their own 1 MiB content 30 times, in 64 KiB pieces, while this process reads
    the path: every read is one writer's whole content, and so is the file left."""
    path = tmp_path / "metrics.csv"
    size = 1 << 20
    wholes = {bytes([65 + i]) * size for i in range(4)}
    atomic_write(path, lambda tmp: tmp.write_bytes(bytes([65]) * size))
    writers = [_python("""
        import sys
        from pathlib import Path
        from mcd.core.atomic_write import atomic_write

        piece = bytes([int(sys.argv[2])]) * (1 << 16)

        def write(tmp):
            with tmp.open("wb") as f:
                for _ in range(16):
                    f.write(piece)
                    f.flush()

        for _ in range(30):
            atomic_write(Path(sys.argv[1]), write)
    """, str(path), str(65 + i)) for i in range(4)]
    reads = 0
    while any(w.poll() is None for w in writers):
        assert path.read_bytes() in wholes
        reads += 1
    assert [w.wait() for w in writers] == [0, 0, 0, 0]
    assert reads > 0 and path.read_bytes() in wholes
    assert _hidden(tmp_path) == []

"""mcd/core/file_lock.py: the one ``flock`` helper of the run directory's lock, the EXR store's scene and
frame locks and the training store's packer lock. ``flock`` treats two ``open`` calls of one file as two
holders, even in one process, so these cases need no second process."""

from __future__ import annotations

import os
import threading

import pytest

from mcd.core import file_lock
from mcd.lit.run_dir import LOCK_NAME, RunDirInUse, hold


def test_a_non_blocking_try_on_a_held_lock_yields_none_and_leaves_the_holders_notes(tmp_path):
    path = tmp_path / "made" / "x.lock"
    with file_lock.exclusive(path) as held:
        held.write("owner notes\n")
        held.flush()
        with file_lock.exclusive(path, blocking=False) as other:
            assert other is None
    assert path.read_text() == "owner notes\n"
    with file_lock.exclusive(path, blocking=False) as again:  # released on leaving the block
        assert again is not None


def test_a_blocking_take_waits_for_the_holder(tmp_path):
    path = tmp_path / "x.lock"
    got: list[bool] = []

    def take() -> None:
        with file_lock.exclusive(path) as f:
            got.append(f is not None)

    with file_lock.exclusive(path):
        waiter = threading.Thread(target=take)
        waiter.start()
        waiter.join(timeout=0.5)
        assert waiter.is_alive() and not got
    waiter.join(timeout=30)
    assert got == [True]


def test_a_second_holder_of_a_run_directory_is_refused_naming_the_owner(tmp_path):
    owner = rf"is in use by another run \(pid {os.getpid()} on "
    with hold(tmp_path / "run"):
        with pytest.raises(RunDirInUse, match=owner) as refused, hold(tmp_path / "run"):
            pass
        assert refused.value.__context__ is None  # one clean error, not one raised while handling another
    assert (tmp_path / "run" / LOCK_NAME).read_text().startswith(f"pid {os.getpid()} on ")

"""The commit of the code a process runs (docs/benchmark.md, "Reports": every record names its commit).

:func:`git_commit` asks git once per process: a sweep's jobs all run the code imported when it started, so a
later commit must not be recorded as theirs. :func:`short_commit` is the same fact as reports print it, and
:func:`commit_word` the one way any commit and dirty flag is printed.
"""

from __future__ import annotations

import functools
import subprocess

from mcd.core.paths import REPO_ROOT


@functools.cache
def git_commit() -> dict[str, object]:
    """``{"commit": <full hash>, "dirty": <tracked files differ>}`` of the checkout the package was imported
    from, as first asked in this process; ``{"commit": "unknown", "dirty": None}`` outside git."""
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO_ROOT, capture_output=True, text=True,
                                check=True).stdout.strip()
        status = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=REPO_ROOT,
                                capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return {"commit": "unknown", "dirty": None}
    return {"commit": commit, "dirty": bool(status.strip())}


def commit_word(commit: object, dirty: object, length: int | None = 10) -> str:
    """A recorded commit as one word: its first ``length`` characters (all of them for None), ``+dirty``
    when its tracked files differed from it."""
    return str(commit)[:length] + ("+dirty" if dirty else "")


def short_commit() -> str:
    """:func:`git_commit` as one word (:func:`commit_word`), or ``unknown``."""
    state = git_commit()
    if state["commit"] == "unknown":
        return "unknown"
    return commit_word(state["commit"], state["dirty"])

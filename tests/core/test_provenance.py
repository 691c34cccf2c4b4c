"""The one way a recorded commit is printed (mcd/core/provenance.py; docs/benchmark.md, "Reports")."""

from mcd.core.provenance import commit_word, git_commit, short_commit
from mcd.reporting.index import _commits
from mcd.reporting.provenance import _segment_text

HASH = "0123456789abcdef0123456789abcdef01234567"


def test_commit_word_lengths_and_dirty_flag():
    assert commit_word(HASH, False) == "0123456789"
    assert commit_word(HASH, True) == "0123456789+dirty"
    assert commit_word(HASH, None, 7) == "0123456"
    assert commit_word(HASH, True, None) == HASH + "+dirty"


def test_short_commit_is_this_checkouts_commit_word():
    state = git_commit()
    assert short_commit() == ("unknown" if state["commit"] == "unknown"
                              else commit_word(state["commit"], state["dirty"]))


def test_report_texts_print_commits_through_commit_word():
    seg = {"start_step": 0, "end_step": 50, "commit": HASH, "dirty": True, "seconds": 120.0}
    assert _segment_text(seg) == "steps 0-50 at 0123456+dirty, 2 min"
    assert _commits(f"{HASH}+dirty, {HASH[::-1]}") == "0123456+dirty, 7654321"

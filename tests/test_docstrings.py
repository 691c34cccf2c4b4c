"""No docstring or comment in ``mcd/`` names a machine or carries a measured or dated figure (the
project's standards): measured facts live in docs and reports' notes with the command, the commit and the
machine, where they can be dated and rerun; code says what it does and cites them."""

from __future__ import annotations

import ast
import io
import re
import tokenize
from pathlib import Path

MCD = Path(__file__).resolve().parents[1] / "mcd"
#: CPU and GPU models and the phrases that stand for the machine at hand.
MACHINE = re.compile(r"\b(EPYC|Xeon|Ryzen|Threadripper|Core i[3579]|[AHV]100|H200|GeForce|RTX ?\d{3,4}|"
                     r"this (machine|box|laptop)|(\d+|two|four|eight|sixteen)[- ]core)\b", re.IGNORECASE)
#: A timing or rate (``37 ms``, ``0.82 s per step``, ``12 GB/s``, ``40 clips/s``), "measured <n>", a date.
FIGURE = re.compile(r"\b\d+(\.\d+)? ?(ms|s per step|s/step|GB/s|MB/s|clips/s|it/s|frames/s|fps|GMAC/s)\b|"
                    r"\bmeasured \d|\b20\d\d-\d\d-\d\d\b")


def prose(source: str) -> list[tuple[int, str]]:
    """``(line, text)`` of every comment and every docstring (modules, classes, functions, and the string
    statements that document attributes) of ``source``."""
    found = [(t.start[0], t.string) for t in tokenize.generate_tokens(io.StringIO(source).readline)
             if t.type == tokenize.COMMENT]
    for node in ast.walk(ast.parse(source)):
        value = node.value if isinstance(node, ast.Expr) else None
        if isinstance(value, ast.Constant) and isinstance(value.value, str):
            found.append((node.lineno, value.value))
    return found


def offences(source: str) -> list[tuple[int, str]]:
    """``(line, match)`` of each machine name or measured figure in ``source``'s comments and docstrings."""
    return [(line, m.group(0)) for line, text in prose(source) for pattern in (MACHINE, FIGURE)
            for m in pattern.finditer(text)]


def test_no_docstring_or_comment_names_a_machine_or_a_measured_figure():
    found = {f"{p.relative_to(MCD.parent)}:{line}": what for p in sorted(MCD.rglob("*.py"))
             for line, what in offences(p.read_text())}
    assert not found, f"move these to docs or a report's notes (command, commit, machine): {found}"


def test_the_check_finds_each_kind_and_passes_code_and_sizes():
    source = '''
"""Runs 37 ms per frame on an EPYC."""
x = "H100"  # the string is code, this comment: 0.82 s per step on this machine
def f():
    """A 1920x1080 map of 16 fp32 channels is 133 MB; measured 10-20x slower on a 2-core box."""
    #: rendered 2026-11-01 at 40 clips/s
'''
    assert offences(source) == [(3, "this machine"), (3, "0.82 s per step"), (6, "2026-11-01"),
                                (6, "40 clips/s"), (2, "EPYC"), (2, "37 ms"), (5, "2-core"),
                                (5, "measured 1")]

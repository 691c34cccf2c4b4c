"""Each method's display name has one definition, its catalogue entry beside its factory (``ENTRIES``,
:data:`mcd.config.methods.FACTORY_MODULES`; docs/architecture.md "Methods"): no other string in ``mcd/``
spells it, so that a table, legend, label or printed comparison cannot drift from the catalogue. Docstrings
that cite a name and error messages (inside ``raise``) are prose about the method, not its label, and are not
counted."""

from __future__ import annotations

import ast
import re
from pathlib import Path

from mcd.config.methods import CATALOGUE, FACTORY_MODULES, MODELS_DIR, entries_assignment

MCD = Path(__file__).resolve().parents[1] / "mcd"
#: The names tables and legends show (the component rows' one-letter names are their experiments).
NAMES = sorted({m.display for m in CATALOGUE if len(m.display) > 1}, key=len, reverse=True)


def spelled_names(source: str, names: list[str] = NAMES) -> list[tuple[int, str]]:
    """``(line, name)`` of every string constant (f-strings' parts too) in ``source`` that holds one of
    ``names`` as a whole word, docstrings and strings inside a ``raise`` statement left out."""
    pattern = re.compile(r"(?<![\w-])(" + "|".join(map(re.escape, names)) + r")(?![\w-])")
    tree = ast.parse(source)
    prose: set[int] = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and body and \
                isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant):
            prose.add(id(body[0].value))
        if isinstance(node, ast.Raise):
            prose |= {id(n) for n in ast.walk(node)}
    return [(node.lineno, m.group(0)) for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in prose
            and (m := pattern.search(node.value))]


def _entries_lines(path: Path) -> range:
    """The lines of a factory module's ``ENTRIES`` assignment."""
    node = entries_assignment(path)
    return range(node.lineno, node.end_lineno + 1)


def test_the_catalogue_is_the_one_place_a_display_name_is_spelled():
    entries = {MODELS_DIR / m: _entries_lines(MODELS_DIR / m) for m in FACTORY_MODULES}
    found, in_catalogue = {}, []
    for p in sorted(MCD.rglob("*.py")):
        for line, name in spelled_names(p.read_text()):
            if line in entries.get(p, ()):
                in_catalogue.append(name)
            else:
                found[f"{p.relative_to(MCD.parent)}:{line}"] = name
    assert not found, f"use mcd.config.methods.display_name(<experiment>) instead of spelling it: {found}"
    assert sorted(in_catalogue) == sorted(NAMES), "each name once, in its entry"


def test_the_check_finds_a_label_and_passes_prose():
    source = '''
"""OIDN, cited in a docstring."""
LEGEND = {"oidn": "OIDN"}
line = f"F / {x} vs U-Net latency"
def f():
    """NTASAD's loss."""
    raise ValueError(f"NTASAD heads at divisors {bad}")
'''
    assert spelled_names(source) == [(3, "OIDN"), (4, "U-Net")]

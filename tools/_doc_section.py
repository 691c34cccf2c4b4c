"""Generated tables inside the repository's documents: a tool that prints a table can also write it between
two marker lines of a Markdown file (``--write FILE``), so that the documented table is the command's output
(``tools/bundle_scores.py``, ``tools/blur_floor.py``)."""

from __future__ import annotations

from pathlib import Path


def markers(name: str) -> tuple[str, str]:
    """The two marker lines of the section ``name``."""
    return f"<!-- {name} -->", f"<!-- /{name} -->"


def check(path: Path, name: str) -> str:
    """The text of ``path`` if it holds one ``<!-- name -->`` line before one ``<!-- /name -->`` line, else
    SystemExit naming the file and the markers; a tool checks this before its long work."""
    begin, end = markers(name)
    doc = path.read_text() if path.is_file() else ""
    if doc.count(begin) != 1 or doc.count(end) != 1 or doc.index(begin) > doc.index(end):
        raise SystemExit(f"{path}: needs one '{begin}' line before one '{end}' line to write the table "
                         "between")
    return doc


def write_section(path: Path, text: str, name: str) -> None:
    """Replace what lies between the lines ``<!-- name -->`` and ``<!-- /name -->`` of ``path`` by ``text``;
    a file without one of each, in that order, is refused naming the markers and left as it was."""
    begin, end = markers(name)
    head, rest = check(path, name).split(begin)
    _, tail = rest.split(end)
    path.write_text(f"{head}{begin}\n{text}{end}{tail}")

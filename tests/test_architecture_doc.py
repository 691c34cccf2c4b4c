"""docs/architecture.md names only what exists, and names every part of ``mcd/``: each path it gives
(``mcd/...``, ``tools/...``, ``scripts/...``, ``tests/...``, ``conf/...``, ``hydra_plugins/...``,
``docs/...``) is a file or folder of the checkout, each bare ``name.py`` is a file somewhere in it, each
dotted ``mcd.x.y`` name is a module or a name defined in one (read from the source, without importing it),
and every top-level module and package of ``mcd/`` is named at least once. The page says it changes with the
code that changes an interface; this keeps it honest when a module moves or is renamed."""

from __future__ import annotations

import ast
import re
from functools import cache
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DOC = REPO / "docs" / "architecture.md"
#: A path of the checkout as the page writes it; ``<name>`` placeholders are matched by any one name.
PATH = re.compile(r"(?<![\w/.<>$-])((?:mcd|tools|scripts|tests|conf|hydra_plugins|docs|notes)/"
                  r"(?:[\w./<>*-]*[\w/*>])?)")
#: A bare Python file name in backticks (``renderer.py``), which some module of the checkout must have.
BARE = re.compile(r"`([a-z_][\w]*\.py)`")
#: A dotted name under the package: ``mcd.models.build``, ``mcd.data.clips.ExrClips.clip``.
DOTTED = re.compile(r"(?<![\w./-])(mcd(?:\.\w+)+)")
#: Folders a bare file name may live in.
CODE_DIRS = ("mcd", "tools", "tests", "scripts", "hydra_plugins")


def named_paths(text: str) -> list[str]:
    return sorted(set(PATH.findall(text)))


def named_files(text: str) -> list[str]:
    return sorted(set(BARE.findall(text)))


def dotted_names(text: str) -> list[str]:
    return sorted(set(DOTTED.findall(text)))


def path_exists(path: str, root: Path = REPO) -> bool:
    """Whether ``path`` (``<name>`` and ``*`` match any one name) names a file or folder under ``root``."""
    pattern = re.sub(r"<[^>]*>", "*", path.rstrip("/"))
    if "*" in pattern:
        return any(True for _ in root.glob(pattern))
    return (root / pattern).exists()


def module_file(parts: list[str], root: Path = REPO) -> Path | None:
    """The source of the module ``.``.join(parts) (a ``.py`` file or a package's ``__init__.py``), or None."""
    base = root.joinpath(*parts)
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


@cache
def defined_names(source: Path) -> dict[str, ast.AST | None]:
    """The names a module defines at its top level: functions, classes, assignments, imports, the entries
    of ``__all__`` and the string keys of a dict assigned at top level (a lazy package's export table)."""
    names: dict[str, ast.AST | None] = {}
    for node in ast.parse(source.read_text()).body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            names[node.name] = node
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            names.update({(a.asname or a.name).split(".")[0]: None for a in node.names})
        elif isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names.update({t.id: None for t in targets if isinstance(t, ast.Name)})
            value = node.value
            if isinstance(value, ast.Dict):
                names.update({k.value: None for k in value.keys
                              if isinstance(k, ast.Constant) and isinstance(k.value, str)})
            if isinstance(value, (ast.List, ast.Tuple)) and any(
                    isinstance(t, ast.Name) and t.id == "__all__" for t in targets):
                names.update({e.value: None for e in value.elts if isinstance(e, ast.Constant)})
    return names


def class_members(node: ast.ClassDef) -> set[str]:
    """The methods and class-level names (dataclass fields too) of a class."""
    members = set()
    for item in node.body:
        if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            members.add(item.name)
        elif isinstance(item, ast.Assign):
            members |= {t.id for t in item.targets if isinstance(t, ast.Name)}
        elif isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name):
            members.add(item.target.id)
    return members


def resolves(dotted: str, root: Path = REPO) -> bool:
    """Whether ``dotted`` is a module of the checkout, or a name that the longest module prefix of it defines
    (and, for a class, a member of that class), read from the source without importing anything."""
    parts = dotted.split(".")
    for cut in range(len(parts), 0, -1):
        source = module_file(parts[:cut], root)
        if source is None:
            continue
        rest = parts[cut:]
        if not rest:
            return True
        names = defined_names(source)
        if rest[0] not in names:
            return False
        node = names[rest[0]]
        return len(rest) == 1 or not isinstance(node, ast.ClassDef) or rest[1] in class_members(node)
    return False


def top_level_parts(root: Path = REPO) -> list[str]:
    """``mcd``'s top-level modules and packages, as ``mcd.<name>``."""
    mcd = root / "mcd"
    modules = [p.stem for p in mcd.glob("*.py") if p.name != "__init__.py"]
    packages = [p.name for p in mcd.iterdir() if (p / "__init__.py").is_file()]
    return sorted(f"mcd.{name}" for name in modules + packages)


def unnamed_parts(text: str, root: Path = REPO) -> list[str]:
    """The top-level modules and packages of ``mcd/`` that ``text`` names neither by path nor dotted."""
    named = {".".join(Path(re.sub(r"\.py$", "", p.rstrip("/"))).parts[:2]) for p in named_paths(text)}
    named |= {".".join(d.split(".")[:2]) for d in dotted_names(text)}
    return [part for part in top_level_parts(root) if part not in named]


def test_every_path_the_page_names_exists():
    missing = [p for p in named_paths(DOC.read_text()) if not path_exists(p)]
    assert not missing, f"docs/architecture.md names paths that do not exist: {missing}"


def test_every_bare_file_name_the_page_gives_is_a_file_of_the_checkout():
    have = {p.name for d in CODE_DIRS for p in (REPO / d).rglob("*.py")}
    missing = [f for f in named_files(DOC.read_text()) if f not in have]
    assert not missing, f"docs/architecture.md names files that no folder holds: {missing}"


def test_every_dotted_name_the_page_gives_resolves():
    missing = [d for d in dotted_names(DOC.read_text()) if not resolves(d)]
    assert not missing, f"docs/architecture.md names modules or attributes that do not exist: {missing}"


def test_every_top_level_module_and_package_of_mcd_is_named():
    missing = unnamed_parts(DOC.read_text())
    assert not missing, f"docs/architecture.md does not name these parts of mcd/: {missing}"


def test_the_checks_find_wrong_names(tmp_path):
    (tmp_path / "mcd" / "data").mkdir(parents=True)
    (tmp_path / "mcd" / "__init__.py").write_text("")
    (tmp_path / "mcd" / "run.py").write_text("def build():\n    pass\n")
    (tmp_path / "mcd" / "data" / "__init__.py").write_text(
        '_EXPORTS = {"StoreReader": "mcd.data.store"}\n__all__ = ["MCDDataModule"]\n')
    (tmp_path / "mcd" / "data" / "store.py").write_text(
        "class StoreReader:\n    kind: str\n    def load(self):\n        pass\n")
    assert resolves("mcd.run.build", tmp_path) and resolves("mcd.data.StoreReader", tmp_path)
    assert resolves("mcd.data.MCDDataModule", tmp_path)
    assert resolves("mcd.data.store.StoreReader.load", tmp_path)
    assert resolves("mcd.data.store.StoreReader.kind", tmp_path)
    for wrong in ("mcd.data.Store", "mcd.run.fit", "mcd.plan", "mcd.data.store.StoreReader.save"):
        assert not resolves(wrong, tmp_path), wrong
    assert path_exists("mcd/data/store.py", tmp_path) and path_exists("mcd/<x>/store.py", tmp_path)
    assert not path_exists("mcd/data/pack.py", tmp_path) and not path_exists("tools/<x>.py", tmp_path)
    text = "`mcd/run.py` runs; `mcd.data.store` stores."
    assert named_paths(text) == ["mcd/run.py"] and dotted_names(text) == ["mcd.data.store"]
    assert unnamed_parts(text, tmp_path) == []
    assert unnamed_parts("`mcd/run.py` only", tmp_path) == ["mcd.data"]


@pytest.mark.parametrize("text, found", [
    ("(`mcd/core/atomic_write.py`: a file)", ["mcd/core/atomic_write.py"]),
    ("the configs (`mcd/conf`, linked as `conf/`)", ["conf/", "mcd/conf"]),
    ("`tools/` (tools/README.md)", ["tools/", "tools/README.md"]),
    ("`<data_dir>/<profile>/<scene>/manifest.json`", []),
    ("`conf/experiment/<X>.yaml` files", ["conf/experiment/<X>.yaml"]),
])
def test_paths_are_read_as_the_page_writes_them(text, found):
    assert named_paths(text) == found

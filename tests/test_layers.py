"""The package's layers (docs/architecture.md, "Layers"), read from the source with ``ast``: no import circle
between modules of ``mcd`` and no import that runs back up a layer. Imports inside functions count too: a
lazy import still ties the two modules together.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

MCD = Path(__file__).resolve().parents[1] / "mcd"

#: The layer of each folder of ``mcd``, lowest first: a module imports its own layer and those below it, never
#: one above. The modules at ``mcd/``'s top level are the commands (``python -m mcd.<name>``), the top layer
#: (:data:`COMMANDS`); ``mcd/__init__.py`` holds the version and imports nothing. A new folder needs its row.
LAYERS: dict[str, int] = {
    "__init__": 0,
    # plumbing and the config's rules: what every layer above may use
    "core": 0,
    # rendering, the stores, the datamodule; sampling maps
    "data": 1, "sampling": 1,
    # networks and losses
    "models": 2, "losses": 2,
    # what a run is asked to be: the methods' catalogue, config composition, the checks before any work
    "config": 3,
    # training, testing and a run's record, directory and counts
    "lit": 4,
    # denoising frames and scenes, reports, benchmarks
    "denoise": 5, "reporting": 5, "bench": 5,
}
#: The layer of the commands, the modules at ``mcd/``'s top level.
COMMANDS = max(LAYERS.values()) + 1


def module_name(path: Path, root: Path = MCD) -> str:
    parts = path.relative_to(root.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(path: Path, modules: set[str], root: Path = MCD) -> set[str]:
    """The ``mcd`` modules ``path`` imports anywhere in its body (``from a import b`` counts as ``a.b``
    where that is a module, else ``a``)."""
    name = module_name(path, root)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                source = ".".join(base + ([node.module] if node.module else []))
            else:
                source = node.module or ""
            for alias in node.names:
                found.add(f"{source}.{alias.name}" if f"{source}.{alias.name}" in modules else source)
    return {m for m in found if m in modules and m != name}


def import_graph(root: Path = MCD) -> dict[str, set[str]]:
    """Module -> the ``mcd`` modules it imports, for every ``.py`` file under ``root``."""
    files = sorted(root.rglob("*.py"))
    modules = {module_name(p, root) for p in files}
    return {module_name(p, root): imports_of(p, modules, root) for p in files}


def part(module: str) -> str:
    pieces = module.split(".")
    return pieces[1] if len(pieces) > 1 else "__init__"


def layer(module: str, root: Path = MCD) -> int:
    """The layer of an ``mcd`` module: its folder's (:data:`LAYERS`), or :data:`COMMANDS` for a module at the
    package's top level; KeyError for a folder without a layer."""
    name = part(module)
    if name in LAYERS:
        return LAYERS[name]
    if (root / f"{name}.py").is_file():
        return COMMANDS
    raise KeyError(f"mcd/{name}/ has no layer: give it one in LAYERS (tests/test_layers.py, "
                   "docs/architecture.md)")


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each sorted."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def upward(graph: dict[str, set[str]], root: Path = MCD) -> list[str]:
    """Every import from a lower layer into a higher one, as ``a (layer) -> b (layer)``."""
    rank = {m: layer(m, root) for m in graph}
    return sorted(f"{a} ({rank[a]}) -> {b} ({rank[b]})" for a, deps in graph.items() for b in deps
                  if rank[b] > rank[a])


def test_no_import_circle():
    assert circles(import_graph()) == [], "import circles between these modules (docs/architecture.md)"


def test_no_import_runs_back_up():
    assert upward(import_graph()) == [], "these imports run back up a layer (LAYERS in this file)"


def lab_imports(root: Path = MCD) -> list[str]:
    """``file: module`` for every import of the lab (the top-level ``tools`` package, tools/README.md) in
    ``root``'s files: the product never needs the lab, which the wheel does not carry."""
    found = []
    for path in sorted(root.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else [])
            found += [f"{path.relative_to(root.parent)}: {n}" for n in names if n.split(".")[0] == "tools"]
    return found


def test_the_product_imports_no_lab_tool(tmp_path):
    assert lab_imports() == [], "mcd imports the lab's tools/ (tools/README.md): move what it needs into mcd"
    (tmp_path / "mcd").mkdir()
    (tmp_path / "mcd" / "report.py").write_text("def f():\n    from tools.stage_ring import ring_mask\n")
    assert lab_imports(tmp_path / "mcd") == ["mcd/report.py: tools.stage_ring"]


def test_the_checks_catch_a_circle_and_an_upward_import(tmp_path):
    """The same checks on a small package with two circles and one upward import find them, and a folder
    without a layer is refused by name."""
    pkg = tmp_path / "mcd"
    for folder in ("core", "data"):
        (pkg / folder).mkdir(parents=True)
    for init in (pkg, pkg / "data", pkg / "core"):
        (init / "__init__.py").write_text("")
    (pkg / "data" / "store.py").write_text("def f():\n    from mcd import complexity\n")
    (pkg / "complexity.py").write_text("from mcd.data.store import f\n")
    (pkg / "core" / "metrics.py").write_text("from . import paths\n")
    (pkg / "core" / "paths.py").write_text("import mcd.core.metrics\n")
    graph = import_graph(pkg)
    assert circles(graph) == [["mcd.complexity", "mcd.data.store"], ["mcd.core.metrics", "mcd.core.paths"]]
    assert upward(graph, pkg) == [f"mcd.data.store (1) -> mcd.complexity ({COMMANDS})"]
    (pkg / "tools").mkdir()
    (pkg / "tools" / "bundle.py").write_text("")
    with pytest.raises(KeyError, match="mcd/tools/ has no layer"):
        upward(import_graph(pkg), pkg)

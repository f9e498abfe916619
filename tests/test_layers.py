"""The house's layers: what each package may import, as docs/architecture.md's table states
it, held against every import of the code (module level, inside functions and under
``TYPE_CHECKING``), and no import circle between modules."""

from __future__ import annotations

import ast
import re
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TABLE = ROOT / "docs" / "architecture.md"
# The installed package's directories: flylog.cli lives in cli/ (pyproject's package-dir).
SOURCES = {"flylog": ROOT / "flylog", "flylog.cli": ROOT / "cli"}


def _modules() -> dict[str, Path]:
    """Every module of the library and the CLI, by its dotted name."""
    found = {}
    for prefix, folder in SOURCES.items():
        for path in folder.rglob("*.py"):
            parts = path.relative_to(folder).with_suffix("").parts
            if parts[-1] == "__init__":
                parts = parts[:-1]
            found[".".join((prefix, *parts))] = path
    return found


def _imports(path: Path, modules: dict[str, Path]) -> Iterator[tuple[str, int]]:
    """(imported flylog module, line) for every import statement of the file, wherever it
    stands; ``from package import name`` names the submodule when ``name`` is one."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [
                f"{node.module}.{a.name}" if f"{node.module}.{a.name}" in modules else node.module
                for a in node.names
            ]
        else:
            continue
        for name in names:
            if name == "flylog" or name.startswith("flylog."):
                yield name, node.lineno


def _layers() -> list[list[str]]:
    """The table's rows, top first: each row's packages or modules (dotted, under flylog)."""
    text = TABLE.read_text(encoding="utf-8")
    block = text.split("<!-- layers: checked by tests/test_layers.py -->", 1)[1]
    block = block.split("<!-- end layers -->", 1)[0]
    rows = [line for line in block.splitlines() if re.match(r"\| *\d+ *\|", line)]
    return [re.findall(r"`([a-z_.0-9]+)`", row.split("|")[2]) for row in rows]


def _place(module: str, layers: list[list[str]]) -> tuple[int, str] | None:
    """(row, entry) of the longest table entry that holds ``module``."""
    best: tuple[int, str] | None = None
    for row, entries in enumerate(layers):
        for entry in entries:
            full = f"flylog.{entry}"
            if (module == full or module.startswith(full + ".")) and (
                best is None or len(entry) > len(best[1])
            ):
                best = (row, entry)
    return best


def test_every_module_has_a_layer():
    layers = _layers()
    assert len(layers) > 10, "docs/architecture.md's layer table was not found"
    unplaced = [m for m in _modules() if m != "flylog" and _place(m, layers) is None]
    assert unplaced == [], "add these to the layer table of docs/architecture.md"


def test_every_import_goes_down_the_layers():
    """A module imports its own package (entry) or an entry of a lower row, nothing else:
    neither a higher row nor another entry of its own row."""
    layers, modules = _layers(), _modules()
    wrong = []
    for module, path in modules.items():
        here = _place(module, layers)
        if here is None:
            continue
        for name, line in _imports(path, modules):
            there = _place(name, layers)
            if there is None or there[1] == here[1]:
                continue
            if there[0] <= here[0]:
                wrong.append(f"{path.relative_to(ROOT)}:{line}: {here[1]} imports {name}")
    assert wrong == []


def _circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
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


def test_no_import_circle_between_modules():
    """A package's ``__init__`` that hands its modules' names on counts as importing them."""
    modules = _modules()
    graph = {
        module: {name for name, _ in _imports(path, modules) if name in modules} - {module}
        for module, path in modules.items()
    }
    assert _circles(graph) == []


def test_the_circle_finder_finds_a_circle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert _circles(graph) == [["a", "b", "c"]]

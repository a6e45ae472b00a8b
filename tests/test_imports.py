"""The import structure: the packages form layers, with no cycles and no private names imported
across modules.

Read from the source with ``ast`` (nothing is imported), so the test also sees imports inside
functions, which Python only runs later. Imports under ``if TYPE_CHECKING:`` are for
annotations only and never run, so they are left out.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# lowest first: a package may import only the ones before it (and itself)
LAYERS = ("common", "scenes", "sim", "mapping", "servo", "scripts")


def _modules() -> dict[str, Path]:
    mods = {}
    for package in LAYERS:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            mods[".".join(parts)] = path
    return mods


def _runtime_nodes(tree: ast.AST):
    """Every node except those under ``if TYPE_CHECKING:``."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            stack.extend(node.orelse)
            continue
        yield node
        stack.extend(ast.iter_child_nodes(node))


def _imports(name: str, path: Path, mods: dict[str, Path]):
    """``(target module, imported name or None, line)`` of each import of a project module."""
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    for node in _runtime_nodes(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name in mods:
                    yield alias.name, None, node.lineno
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parent = package[: len(package) - node.level + 1]
                base = ".".join([*parent, base] if base else parent)
            for alias in node.names:
                if f"{base}.{alias.name}" in mods:  # a submodule
                    yield f"{base}.{alias.name}", None, node.lineno
                elif base in mods:
                    yield base, alias.name, node.lineno


@pytest.fixture(scope="module")
def graph():
    mods = _modules()
    return {name: list(_imports(name, path, mods)) for name, path in mods.items()}


def _cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """One cycle of the graph, or None (depth-first search, colouring the nodes)."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done

    def visit(node, path):
        state[node] = 1
        for nxt in sorted(edges[node]):
            if state.get(nxt) == 1:
                return [*path[path.index(nxt) :], nxt]
            if nxt not in state and (found := visit(nxt, [*path, nxt])):
                return found
        state[node] = 2
        return None

    for start in sorted(edges):
        if start not in state and (found := visit(start, [start])):
            return found
    return None


def test_the_cycle_finder_finds_cycles():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) is None


def test_no_import_cycles(graph):
    edges = {m: {t for t, _, _ in imports if t != m} for m, imports in graph.items()}
    assert _cycle(edges) is None, f"import cycle: {' -> '.join(_cycle(edges))}"


def test_no_private_names_imported_across_modules(graph):
    bad = [
        f"{m}:{line} imports {name} from {target}"
        for m, imports in graph.items()
        for target, name, line in imports
        if name is not None and name.startswith("_") and target != m
    ]
    assert not bad, "\n".join(bad)


def test_lower_layers_never_import_higher_ones(graph):
    rank = {package: i for i, package in enumerate(LAYERS)}
    bad = [
        f"{m}:{line} imports {target}"
        for m, imports in graph.items()
        for target, _, line in imports
        if rank[target.split(".")[0]] > rank[m.split(".")[0]]
    ]
    assert not bad, "\n".join(bad)

"""The import structure: the packages form layers, with no cycles; each subpackage is entered
through its face; the two servo controllers stand apart; nothing private crosses a package.

Read from the source with ``ast`` (nothing is imported), so the test also sees imports inside
functions, which Python only runs later. Imports under ``if TYPE_CHECKING:`` are for
annotations only and never run, so they are left out.
"""

from __future__ import annotations

import ast
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# lowest first: a package may import only the ones before it (and itself). ``bench`` and
# ``experiments`` are not installed; they sit above everything the wheel holds.
LAYERS = ("common", "scenes", "sim", "mapping", "servo", "scripts", "bench", "experiments")
INSTALLED = LAYERS[:6]
# code that may reach into a subpackage past its face
REACH_IN = ("tests", "experiments")
CONTROLLERS = ("servo.laser_image", "servo.camera_only")
MAX_MODULES = 15  # modules directly in one folder of the installed packages
# lines of code and comments in one module of the installed packages; docstrings do not count,
# so that numpydoc's Parameters and Returns sections never push code out of its module
MAX_CODE_LINES = 400


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {
        _module_name(path): path
        for package in LAYERS
        for path in sorted((ROOT / package).rglob("*.py"))
    }


def _packages(mods: dict[str, Path]) -> set[str]:
    return {name for name, path in mods.items() if path.name == "__init__.py"}


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
def mods():
    return _modules()


@pytest.fixture(scope="module")
def graph(mods):
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


def _inside(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


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


def test_no_private_module_imported_across_packages(graph, mods):
    """A module named ``_x`` is its package's own: no other package imports it."""
    packages = _packages(mods)
    bad = []
    for m, imports in graph.items():
        for target, _, line in imports:
            owner, _, leaf = target.rpartition(".")
            if leaf.startswith("_") and target not in packages and not _inside(m, owner):
                bad.append(f"{m}:{line} imports the private module {target}")
    assert not bad, "\n".join(bad)


def _upward_imports(graph) -> list[str]:
    rank = {package: i for i, package in enumerate(LAYERS)}
    return [
        f"{m}:{line} imports {target}"
        for m, imports in graph.items()
        for target, _, line in imports
        if rank[target.split(".")[0]] > rank[m.split(".")[0]]
    ]


def test_lower_layers_never_import_higher_ones(graph):
    bad = _upward_imports(graph)
    assert not bad, "\n".join(bad)


def test_the_layer_check_sees_the_product_import_a_study():
    planted = {
        "scripts.cli": [("experiments.servo.lawn_survey", None, 7)],
        "bench.run_all": [("scripts.tables", "Table", 3)],
    }
    assert _upward_imports(planted) == ["scripts.cli:7 imports experiments.servo.lawn_survey"]


def test_subpackages_are_entered_through_their_face(graph, mods):
    """Outside a subpackage (a package below a top-level one), code imports it only through its
    ``__init__``; tests and experiments may reach in."""
    subpackages = {p for p in _packages(mods) if "." in p}
    bad = []
    for m, imports in graph.items():
        if m.split(".")[0] in REACH_IN:
            continue
        for target, _, line in imports:
            for sub in subpackages:
                if target != sub and _inside(target, sub) and not _inside(m, sub):
                    bad.append(f"{m}:{line} reaches into {sub} ({target})")
    assert not bad, "\n".join(sorted(set(bad)))


def _controller_crossings(graph) -> list[str]:
    return [
        f"{m}:{line} imports {target}"
        for m, imports in graph.items()
        for target, _, line in imports
        for one, other in (CONTROLLERS, CONTROLLERS[::-1])
        if _inside(m, one) and _inside(target, other)
    ]


def test_the_two_controllers_never_import_each_other(graph):
    bad = _controller_crossings(graph)
    assert not bad, "\n".join(bad)


def test_the_controller_check_sees_a_crossing():
    planted = {
        "servo.camera_only.controller": [
            ("servo.laser_image", "ManifoldServo", 9),
            ("servo.route", "RouteGraph", 10),
        ],
        "servo.task.evaluation": [("servo.camera_only", "SignalServo", 4)],
    }
    expected = ["servo.camera_only.controller:9 imports servo.laser_image"]
    assert _controller_crossings(planted) == expected


def test_no_folder_of_the_installed_packages_holds_too_many_modules():
    crowded = {
        str(folder.relative_to(ROOT)): n
        for package in INSTALLED
        for folder in [ROOT / package, *(p for p in (ROOT / package).rglob("*") if p.is_dir())]
        if (n := len(list(folder.glob("*.py")))) > MAX_MODULES
    }
    assert not crowded, f"more than {MAX_MODULES} modules in one folder: {crowded}"


def code_lines(source: str) -> int:
    """Count the lines of ``source`` outside its docstrings (module, class and function)."""
    docstrings = set()
    for node in ast.walk(ast.parse(source)):
        kinds = (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)
        if isinstance(node, kinds) and node.body and ast.get_docstring(node, clean=False):
            first = node.body[0]
            docstrings.update(range(first.lineno, first.end_lineno + 1))
    return source.count("\n") - len(docstrings)


def test_no_module_of_the_installed_packages_is_too_long(mods):
    long = {
        name: n
        for name, path in mods.items()
        if name.split(".")[0] in INSTALLED and (n := code_lines(path.read_text())) > MAX_CODE_LINES
    }
    assert not long, f"more than {MAX_CODE_LINES} lines of code in a module: {long}"


def test_the_length_check_leaves_docstrings_out():
    body = "    x = 1\n" * 3
    source = f'"""Module."""\n\n\ndef f():\n    """Do.\n\n    More.\n    """\n{body}'
    assert code_lines(source) == 2 + 1 + 3


def test_no_face_exports_a_name_that_is_also_a_submodule(mods):
    """``from package import x`` must give the same thing whatever was imported before: a
    public name that is also a submodule's name is replaced by the module once that module is
    imported."""
    bad = []
    for package in _packages(mods):
        if package.split(".")[0] not in INSTALLED:
            continue
        tree = ast.parse(mods[package].read_text())
        exported = set()
        for node in ast.walk(tree):
            if isinstance(node, ast.Dict) and all(
                isinstance(k, ast.Constant) and isinstance(k.value, str) for k in node.keys
            ):
                exported |= {k.value for k in node.keys}
            if isinstance(node, ast.Assign) and any(
                isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets
            ):
                try:
                    exported |= set(ast.literal_eval(node.value))
                except ValueError:  # computed (``sorted(_EXPORTS)``): the dict's keys count
                    pass
        folder = mods[package].parent
        submodules = {p.stem for p in folder.glob("*.py")} | {
            p.name for p in folder.iterdir() if (p / "__init__.py").exists()
        }
        bad += [f"{package}.{name}" for name in sorted(exported & submodules)]
    assert not bad, f"exported names that are also submodules: {bad}"


def test_the_wheel_holds_the_installed_packages_only():
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    include = config["tool"]["setuptools"]["packages"]["find"]["include"]
    assert sorted(include) == sorted(f"{p}*" for p in INSTALLED)


# The modules outside ``scenes`` that may read its lists of the canonical worlds: each keys
# something by a canonical world's position (seeds, so that the canonical datasets and
# episodes keep their bytes) or expands "all" into the canonical worlds. Everything else takes
# a world's manifolds and names from the world or the dataset.
CANONICAL_LIST_READERS = {
    "scripts.args": "--world all: the canonical worlds",
    "scripts.grouping.loop_recordings": "a loop's seed index by canonical world",
    "servo.task.protocol": "episode seeds keyed by the world's position",
    "sim.collect": "the default dataset holds the canonical worlds",
    "sim.collect_worlds": "sequence seeds and label ids keyed by canonical world",
}


def _reads_canonical_lists(path: Path) -> bool:
    for node in _runtime_nodes(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Name) and node.id in ("WORLDS", "MANIFOLDS"):
            return True
        if isinstance(node, ast.Attribute) and node.attr in ("WORLDS", "MANIFOLDS"):
            return True
        if isinstance(node, ast.alias) and node.name in ("WORLDS", "MANIFOLDS"):
            return True
    return False


def test_worlds_are_data_outside_scenes(mods):
    readers = {
        name
        for name, path in mods.items()
        if name.split(".")[0] in INSTALLED
        and not _inside(name, "scenes")
        and _reads_canonical_lists(path)
    }
    assert readers == set(CANONICAL_LIST_READERS)


def test_the_world_list_check_sees_a_reader(tmp_path):
    path = tmp_path / "m.py"
    path.write_text("from scenes import MANIFOLDS\n")
    assert _reads_canonical_lists(path)
    path.write_text("from scenes import names\nx = names.WORLDS\n")
    assert _reads_canonical_lists(path)
    path.write_text("x = world.manifold_names\n")
    assert not _reads_canonical_lists(path)

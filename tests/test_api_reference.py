"""The API reference (docs/api/, built by mkdocs) shows every public name of every package
face, and every public class there is documented like a scikit-learn estimator."""

import importlib
import inspect
import re
from pathlib import Path

import pytest

API = Path(__file__).resolve().parents[1] / "docs" / "api"
FACES = (
    "mapping",
    "mapping.manifold",
    "mapping.grouping",
    "mapping.scan_matching",
    "mapping.baselines",
    "mapping.features",
    "servo",
    "servo.maps",
    "servo.task",
    "servo.laser_image",
    "servo.camera_only",
    "sim.readers",
    "sim.dataset",
    "sim.wrappers",
    "scenes",
)
# sim's face exports nothing itself: users import its modules, which its page renders whole
SIM_MODULES = ("sim.simulator", "sim.env", "sim.collect")
SECTIONS = ("Parameters", "Attributes", "Examples", "See Also")
DIRECTIVE = re.compile(r"^::: ([\w.]+)\s*$", re.M)


def resolve(path: str):
    """The object at a dotted path: the longest importable module, then its attributes."""
    parts = path.split(".")
    for cut in range(len(parts), 0, -1):
        try:
            value = importlib.import_module(".".join(parts[:cut]))
        except ImportError:
            continue
        for part in parts[cut:]:
            value = getattr(value, part)
        return value
    raise ImportError(path)


def directives(page: Path) -> list[str]:
    return DIRECTIVE.findall(page.read_text())


def rendered() -> list:
    return [resolve(path) for page in sorted(API.glob("*.md")) for path in directives(page)]


def test_every_directive_names_an_object():
    paths = [path for page in sorted(API.glob("*.md")) for path in directives(page)]
    assert len(paths) > 50
    for path in paths:
        resolve(path)  # raises on a misspelt or removed name


@pytest.mark.parametrize("face", FACES)
def test_every_name_a_face_exports_is_on_the_api_pages(face):
    module = importlib.import_module(face)
    shown = rendered()
    page = (API / f"{face}.md").read_text()
    missing = [
        name
        for name in module.__all__
        if not any(getattr(module, name) is value for value in shown)
    ]
    assert not missing, f"{face}: not rendered on any page of docs/api/: {missing}"
    unnamed = [
        name
        for name in module.__all__
        if f"`{name}`" not in page and not re.search(rf"^::: [\w.]*\.{name}\s*$", page, re.M)
    ]
    assert not unnamed, f"docs/api/{face}.md does not name {unnamed}"


def test_the_sim_page_renders_its_modules():
    assert set(SIM_MODULES) <= set(directives(API / "sim.md"))


def public_classes() -> dict[str, type]:
    classes = {}
    for face in FACES:
        module = importlib.import_module(face)
        for name in module.__all__:
            value = getattr(module, name)
            if inspect.isclass(value):
                classes[f"{value.__module__}.{value.__qualname__}"] = value
    for name in SIM_MODULES:
        for value in vars(importlib.import_module(name)).values():
            if inspect.isclass(value) and value.__module__ == name and value.__name__[0] != "_":
                classes[f"{name}.{value.__qualname__}"] = value
    # an exception carries its message only; it has no parameters or attributes to document
    return {key: value for key, value in classes.items() if not issubclass(value, BaseException)}


@pytest.mark.parametrize("path", sorted(public_classes()))
def test_a_public_class_is_documented_like_an_estimator(path):
    cls = public_classes()[path]
    doc = inspect.getdoc(cls) or ""
    # a class built without arguments (a mixin), or never built (an interface, a
    # typing.Protocol), has neither parameters nor state to describe
    built = inspect.signature(cls).parameters and not getattr(cls, "_is_protocol", False)
    sections = SECTIONS if built else ("Examples", "See Also")
    absent = [s for s in sections if not re.search(rf"^{s}\n-{{{len(s)}}}$", doc, re.M)]
    assert not absent, f"{path}: its docstring lacks the numpydoc sections {absent}"


@pytest.mark.parametrize("path", sorted(public_classes()))
def test_the_docs_a_public_class_names_exist(path):
    doc = inspect.getdoc(public_classes()[path]) or ""
    named = re.findall(r"docs/[\w./-]+\.md", doc)
    missing = [page for page in named if not (API.parents[1] / page).is_file()]
    assert not missing, f"{path} names pages that do not exist: {missing}"


@pytest.mark.parametrize("path", sorted(public_classes()))
def test_the_public_methods_of_a_public_class_have_docstrings(path):
    cls = public_classes()[path]
    bare = []
    for name, value in vars(cls).items():
        function = value.fget if isinstance(value, property) else getattr(value, "__func__", value)
        # its own docstring: one inherited from a library base class does not describe it
        if not name.startswith("_") and callable(function) and not (function.__doc__ or "").strip():
            bare.append(name)
    assert not bare, f"{path}: public methods without a docstring: {bare}"


def imported_names(page: Path) -> list[str]:
    """The names the import lines of a page's first Python block bring in, in order."""
    block = re.search(r"```python\n(.*?)```", page.read_text(), re.S)
    lines = block.group(1).splitlines() if block else []
    return [
        name.strip()
        for line in lines
        if (m := re.match(r"from [\w.]+ import ([\w, ]+)", line))
        for name in m.group(1).split(",")
    ]


@pytest.mark.parametrize("page", sorted(API.glob("*.md")), ids=lambda page: page.stem)
def test_a_page_lists_the_names_users_import_before_the_rest(page):
    """Within each section of a page (Classes, Functions...), the objects its import line names
    come first, in that order: ``ManifoldClustering`` heads its page, its internals follow."""
    names = imported_names(page)
    for section in re.split(r"^## ", page.read_text(), flags=re.M):
        shown = [path.rsplit(".", 1)[-1] for path in DIRECTIVE.findall(section)]
        ranks = [names.index(name) if name in names else len(names) for name in shown]
        assert ranks == sorted(ranks), f"{page.name}: {shown} (imported first: {names})"

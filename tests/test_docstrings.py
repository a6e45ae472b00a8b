"""Every object the API reference renders (docs/api/), and every public function, class and
method of the installed packages, documents its parameters and what it returns in numpydoc
sections, checked by numpydoc's own validator; the docstrings' layout is ruff's D rules under
the numpy convention (pyproject.toml), run by the test command."""

import inspect

import pytest
from numpydoc.validate import validate

from tests.test_api_reference import API, directives, resolve
from tests.test_imports import INSTALLED, ROOT

# numpydoc's codes this test holds every rendered object to: a docstring at all, every
# parameter documented and none that does not exist, a Returns section where the code returns
# a value and a Yields section where it yields
CODES = {"GL08", "PR01", "PR02", "RT01", "YD01"}


def members(path: str) -> list[str]:
    """Dotted paths of what one ``::: path`` directive renders: a module's public functions and
    classes, a class and its public methods and properties, or a function.
    """
    obj = resolve(path)
    if inspect.ismodule(obj):
        names = [
            name
            for name, value in vars(obj).items()
            if not name.startswith("_")
            and (inspect.isfunction(value) or inspect.isclass(value))
            and value.__module__ == obj.__name__
        ]
        return [p for name in names for p in members(f"{path}.{name}")]
    if inspect.isclass(obj):
        own = [
            name
            for name, value in vars(obj).items()
            if not name.startswith("_")
            and (
                inspect.isfunction(value)
                or isinstance(value, (property, classmethod, staticmethod))
            )
        ]
        return [path] + [f"{path}.{name}" for name in own]
    return [path]


def rendered_paths() -> list[str]:
    paths = []
    for page in sorted(API.glob("*.md")):
        for path in directives(page):
            paths.extend(p for p in members(path) if p not in paths)
    return paths


def problems_of(path: str) -> list[str]:
    """Return numpydoc's errors of ``CODES`` for the object at ``path``.

    A ``typing.Protocol`` is an interface that is never instantiated: the ``*args, **kwargs``
    numpydoc reads on its generated constructor are not parameters to document (the API pages'
    renderer, griffe, refuses them as not in the signature).
    """
    interface = inspect.isclass(obj := resolve(path)) and getattr(obj, "_is_protocol", False)
    return [
        f"{code}: {message}"
        for code, message in validate(path)["errors"]
        if code in CODES and not (interface and code == "PR01")
    ]


@pytest.mark.parametrize("path", rendered_paths())
def test_rendered_object_documents_its_parameters_and_returns(path):
    problems = problems_of(path)
    assert not problems, f"{path}:\n" + "\n".join(problems)


def public_modules() -> list[str]:
    """List the modules of the installed packages whose dotted path has no private part."""
    names = []
    for package in INSTALLED:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            if not any(part.startswith("_") for part in parts):
                names.append(".".join(parts))
    return names


@pytest.mark.parametrize("module", public_modules())
def test_public_objects_document_their_parameters_and_returns(module):
    problems = [f"{path}: {problem}" for path in members(module) for problem in problems_of(path)]
    assert not problems, "\n".join(problems)


def test_the_check_sees_an_undocumented_parameter():
    # a planted function with a parameter and a return value that its docstring leaves out
    codes = {code for code, _ in validate("tests.test_docstrings._planted")["errors"]}
    assert {"PR01", "RT01"} <= codes


def _planted(x):
    """Return twice the value."""
    return 2 * x

"""The Examples of the public modules' docstrings run and print what they show.

The modules are those defining the names of the package faces (and the ``sim`` modules users
import directly). The examples run in one working directory shared by all modules, so the
small dataset and servo map that several servo examples collect and build are made once and
resumed from disk after.
"""

import doctest
import importlib
import inspect
import types

import pytest

import sim  # noqa: F401  (headless GL before anything imports mujoco)
from tests.test_api_reference import FACES, SIM_MODULES

OPTIONS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def public_modules() -> list[str]:
    names = set(SIM_MODULES)
    for face in FACES:
        module = importlib.import_module(face)
        for name in module.__all__:
            value = getattr(module, name)
            if isinstance(value, types.ModuleType):
                names.add(value.__name__)
            elif inspect.isclass(value) or inspect.isfunction(value):
                names.add(value.__module__)
    return sorted(
        name
        for name in names
        if name.split(".")[0] in {"common", "scenes", "sim", "mapping", "servo"}
    )


@pytest.fixture(scope="module")
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp("examples")


def test_the_public_modules_have_examples():
    tests = [
        t
        for name in public_modules()
        for t in doctest.DocTestFinder().find(importlib.import_module(name))
        if t.examples
    ]
    assert len(tests) >= 30


@pytest.mark.parametrize("name", public_modules())
def test_docstring_examples(name, workdir, monkeypatch):
    monkeypatch.chdir(workdir)
    module = importlib.import_module(name)
    runner = doctest.DocTestRunner(optionflags=OPTIONS)
    report = []
    # no module globals: an example imports what it uses, so that it runs where it is pasted
    for test in doctest.DocTestFinder().find(module, globs={"__name__": name}):
        runner.run(test, out=report.append)
    assert runner.failures == 0, "".join(report)

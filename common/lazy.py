"""Package faces whose public names load on first use.

A face lists each public name beside the module that defines it; the module is imported the
first time the name is read (``from package import name`` or ``package.name``), so importing
a package costs nothing until its parts are used (``topomap --help`` stays fast, and a
lightweight name such as the servo policies' list does not load the controllers).
"""

from __future__ import annotations

import sys
from importlib import import_module

__all__ = ["lazy_exports"]


def lazy_exports(package: str, exports: dict[str, str], modules: dict[str, str] | None = None):
    """Build the ``(__getattr__, __dir__, __all__)`` of the face of ``package``.

    Parameters
    ----------
    package : str
        The package's name (``__name__`` in its ``__init__``).
    exports : dict of str to str
        Public name -> ``"module"`` (the module defining that name) or ``"module:attribute"``
        (the name is the module's ``attribute``, exported under another name).
    modules : dict of str to str, optional
        Public name -> module served as itself.

    Returns
    -------
    tuple
        ``__getattr__`` and ``__dir__`` for the package's module, and its sorted ``__all__``.
    """
    modules = dict(modules or {})
    clash = set(exports) & set(modules)
    if clash:
        raise ValueError(f"{package}: names both exported and served as modules: {sorted(clash)}")

    def __getattr__(name: str):
        if name in modules:
            value = import_module(modules[name])
        elif name in exports:
            module, _, attribute = exports[name].partition(":")
            value = getattr(import_module(module), attribute or name)
        else:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        # not stored on the package: a name read later is looked up again, so it follows its
        # module (a test that patches the defining module patches what the face gives)
        return value

    names = sorted((*exports, *modules))

    def __dir__() -> list[str]:
        return sorted({*names, *vars(sys.modules[package])})

    return __getattr__, __dir__, names

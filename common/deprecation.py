"""Old import paths kept working for one release after a module moves.

A moved module leaves a small module at its old path whose ``__getattr__`` gives each name from
its new home and warns, naming the path to import from instead::

    __getattr__, __dir__, __all__ = moved_names(__name__, {"icp": "mapping.scan_matching"})
"""

from __future__ import annotations

import sys
import warnings
from importlib import import_module

__all__ = ["moved_names"]


def moved_names(old: str, new: dict[str, str], others=None):
    """Build the ``(__getattr__, __dir__, __all__)`` of the module left at the old path ``old``.

    Parameters
    ----------
    old : str
        The old module's name (``__name__`` in it).
    new : dict of str to str
        Old public name -> ``"module"`` (the module to import it from now, under the same name)
        or ``"module:attribute"`` (renamed: import ``attribute`` from ``module``).
    others : callable, optional
        The module's own ``__getattr__`` for every other name (a package face's lazy names);
        without it, other names raise ``AttributeError``.

    Returns
    -------
    tuple
        ``__getattr__`` (the name from its new module, with a ``DeprecationWarning`` naming
        that module) and ``__dir__`` for the old module, and its sorted ``__all__``.
    """

    def __getattr__(name: str):
        if name not in new:
            if others is not None:
                return others(name)
            raise AttributeError(f"module {old!r} has no attribute {name!r}")
        module, _, attribute = new[name].partition(":")
        attribute = attribute or name
        warnings.warn(
            f"{old}.{name} is deprecated and will be removed in the next release: import "
            f"{attribute} from {module} instead",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(import_module(module), attribute)

    names = sorted(new)

    def __dir__() -> list[str]:
        return sorted({*names, *vars(sys.modules[old])})

    return __getattr__, __dir__, names

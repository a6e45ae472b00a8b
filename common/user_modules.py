"""A user's own module, named on a command line or in a spec (``package.module:name``),
imported as ``python -m`` would: the current directory first on ``sys.path``, so a module
beside the user's working directory is found. Importing it runs its code."""

from __future__ import annotations

import importlib
import os
import sys
from types import ModuleType

__all__ = ["UserModuleError", "import_user_module"]


class UserModuleError(ValueError):
    """A user's module that does not import; the message names it and what it raised."""


def import_user_module(name: str) -> ModuleType:
    """The module ``name``, imported with the current directory first on ``sys.path``.

    Raises `UserModuleError` ("module 'name' does not import (Error: message)") when
    the import raises anything: whatever a user's module raises is theirs to see.

    Examples
    --------
    >>> from common.user_modules import import_user_module
    >>> import_user_module("json").__name__
    'json'
    """
    cwd = os.getcwd()
    if cwd not in sys.path:
        sys.path.insert(0, cwd)
    try:
        return importlib.import_module(name)
    except Exception as err:
        raise UserModuleError(
            f"module {name!r} does not import ({type(err).__name__}: {err})"
        ) from err

"""A user's own module, imported as ``python -m`` would.

The module is named on a command line or in a spec (``package.module:name``) and imported with
the current directory first on ``sys.path``, so a module beside the user's working directory
is found. Importing it runs its code.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import sys
from pathlib import Path
from types import ModuleType

__all__ = ["UserModuleError", "import_user_module", "source_digest"]

MAX_SOURCE_FILES = 500  # files of a package folder hashed at most


class UserModuleError(ValueError):
    """A user's module that does not import; the message names it and what it raised."""


def import_user_module(name: str) -> ModuleType:
    """Import the module ``name`` with the current directory first on ``sys.path``.

    Raises `UserModuleError` ("module 'name' does not import (Error: message)") when
    the import raises anything: whatever a user's module raises is theirs to see.

    Parameters
    ----------
    name : str
        Dotted module name.

    Returns
    -------
    ModuleType
        The imported module.

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


def source_digest(name: str) -> dict:
    """Return the provenance of module ``name`` without importing anything.

    The module is found as `import_user_module` would find it (the current directory, then
    ``sys.path``): ``{"module", "files", "sha256"}``, the SHA-256 over the module's file and
    the other ``.py`` files of its folder (its package's code), each by its name and bytes;
    ``sha256`` None when the module is no source file there (a built-in or compiled module, or
    none).

    Parameters
    ----------
    name : str
        Dotted module name.

    Returns
    -------
    dict
        ``{"module": name, "files": int, "sha256": str or None}``.

    Examples
    --------
    >>> from common.user_modules import source_digest
    >>> d = source_digest("common.user_modules")
    >>> d["files"] >= 1 and len(d["sha256"])
    64
    """
    parts = str(name).split(".")
    for root in [os.getcwd(), *sys.path]:
        base = Path(root or ".", *parts)
        for path in (base.with_suffix(".py"), base / "__init__.py"):
            if path.is_file():
                files = sorted(path.parent.glob("*.py"))[:MAX_SOURCE_FILES]
                h = hashlib.sha256()
                for f in files:
                    h.update(f.name.encode() + b"\0" + f.read_bytes() + b"\0")
                return {"module": name, "files": len(files), "sha256": h.hexdigest()}
    return {"module": name, "files": 0, "sha256": None}

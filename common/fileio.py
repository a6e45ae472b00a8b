"""Atomic file writes, JSON coercion and reading JSON that may be damaged: the one home for
each.

A write goes to a temporary file in the same directory, then a rename, so a reader never sees
half a file and a failed write leaves nothing behind. JSON goes through :func:`jsonable` first,
so numpy scalars, arrays and paths from a result need no per-caller conversion.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

__all__ = [
    "UnreadableJSON",
    "atomic_path",
    "atomic_write_bytes",
    "jsonable",
    "read_json",
    "write_json",
    "write_png",
]

_JSON_SCALARS = (str, int, float, bool, type(None))


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """A temporary path beside ``path`` to write to; renamed onto ``path`` when the block ends
    without error, removed when it raises (for writers that need a file name, e.g. a zip)."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically; nothing is left behind on failure."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def jsonable(obj, finite: bool = False):
    """``obj`` with what ``json`` cannot write converted, recursively.

    numpy scalars become Python numbers, numpy arrays nested lists, tuples lists, paths POSIX
    strings; dict keys that are numpy scalars become Python scalars and other non-scalar keys
    their ``str``. With ``finite``, NaN and infinities become None (strict JSON's null).
    Anything else that JSON has no form for raises ``TypeError`` naming its type.
    """
    if isinstance(obj, dict):
        return {_key(k): jsonable(v, finite) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [jsonable(v, finite) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist(), finite) if finite else obj.tolist()
    if isinstance(obj, np.generic):
        obj = obj.item()
        return None if finite and _non_finite(obj) else obj
    if isinstance(obj, Path):
        return obj.as_posix()
    if isinstance(obj, _JSON_SCALARS):
        return None if finite and _non_finite(obj) else obj
    raise TypeError(f"{type(obj).__name__} is not JSON serialisable")


def _non_finite(value) -> bool:
    return isinstance(value, float) and not math.isfinite(value)


def _key(key):
    key = key.item() if isinstance(key, np.generic) else key
    return key if isinstance(key, _JSON_SCALARS) else str(key)


class UnreadableJSON(ValueError):
    """A file that does not parse as JSON; its message is the parser's reason."""


def read_json(path: str | os.PathLike):
    """The JSON value in the UTF-8 file ``path``; :class:`UnreadableJSON` for bad UTF-8, bad
    syntax, or nesting deeper than the parser's stack (100,000 ``[`` raise RecursionError,
    which is no ValueError), so that each reader turns all three into its own error."""
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (ValueError, RecursionError) as err:  # ValueError: bad JSON or bad UTF-8
        raise UnreadableJSON(str(err)) from err


def write_json(path: str | os.PathLike, obj, indent: int = 2, finite: bool = False) -> None:
    """Write ``jsonable(obj, finite)`` as indented JSON with a final newline, atomically."""
    text = json.dumps(jsonable(obj, finite), indent=indent) + "\n"
    atomic_write_bytes(path, text.encode())


def write_png(path: str | os.PathLike, rgb: np.ndarray) -> Path:
    """Write an RGB ``(H, W, 3)`` uint8 image as a PNG atomically (its folder is created)."""
    import cv2  # only the writers of figures need OpenCV

    path = Path(path)
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(np.asarray(rgb)[..., ::-1]))
    if not ok:
        raise RuntimeError(f"could not encode {path} as PNG")
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, buf.tobytes())
    return path

"""Atomic file writes, JSON coercion, opening untrusted files and reading damaged JSON.

This module is the one home for each.

A write goes to a temporary file in the same directory, then a rename, so a reader never sees
half a file and a failed write leaves nothing behind. JSON goes through `jsonable` first,
so numpy scalars, arrays and paths from a result need no per-caller conversion.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import stat
import tempfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np

__all__ = [
    "MAX_JSON_BYTES",
    "NotARegularFile",
    "UnreadableJSON",
    "atomic_path",
    "atomic_write_bytes",
    "jsonable",
    "open_regular",
    "read_json",
    "write_json",
    "write_png",
]

_JSON_SCALARS = (str, int, float, bool, type(None))
# the largest JSON file read: a description, a settings file or a result file of a thousand
# episodes is a few MB; parsing takes several times the file's size in memory
MAX_JSON_BYTES = 64 << 20


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike) -> Iterator[Path]:
    """Give a temporary path beside ``path`` to write to, renamed onto ``path`` at the end.

    The temporary file is renamed onto ``path`` when the block ends without error and removed
    when it raises (for writers that need a file name, e.g. a zip).

    Parameters
    ----------
    path : path-like
        The file to write in the end.

    Yields
    ------
    Path
        The temporary path to write to, in ``path``'s folder.
    """
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
    """Write ``data`` to ``path`` atomically; nothing is left behind on failure.

    Parameters
    ----------
    path : path-like
        The file to write.
    data : bytes
        Its new content.
    """
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
    """Convert, recursively, what ``json`` cannot write in ``obj``.

    numpy scalars become Python numbers, numpy arrays nested lists, tuples lists, paths POSIX
    strings; dict keys that are numpy scalars become Python scalars and other non-scalar keys
    their ``str``. With ``finite``, NaN and infinities become None (strict JSON's null).
    Anything else that JSON has no form for raises ``TypeError`` naming its type.

    Parameters
    ----------
    obj : object
        The value to convert.
    finite : bool, default False
        Turn NaN and infinities into None.

    Returns
    -------
    object
        A value of dicts, lists, strings, numbers, bools and None.
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


class NotARegularFile(OSError):
    """A path that is no regular file: reading it could block forever or never end.

    It is a folder, a named pipe, a device, a socket, or a link to one of these.
    """


_KINDS = (
    (stat.S_ISDIR, "a folder"),
    (stat.S_ISFIFO, "a named pipe"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def _kind(mode: int) -> str:
    return next((name for test, name in _KINDS if test(mode)), "no regular file")


def open_regular(path: str | os.PathLike):
    """Open ``path`` for binary reading, once it is known to be a regular file.

    A link is followed to its target, which must be a regular file too. The kind of file is
    checked before it is opened, and again on the open descriptor (opened without blocking,
    so that a pipe put in its place in between cannot block either).

    Parameters
    ----------
    path : path-like
        The file to open.

    Returns
    -------
    file object
        The file, opened ``"rb"``.

    Raises
    ------
    NotARegularFile
        Naming the path and what it is instead (``"a named pipe"``, ``"a link to a character
        device"``, ...); an ``OSError``, so readers that turn ``OSError`` into their own error
        need nothing more.
    """
    path = Path(path)
    mode = os.stat(path).st_mode  # FileNotFoundError for nothing there, as open's
    if not stat.S_ISREG(mode):
        link = "a link to " if path.is_symlink() else ""
        raise NotARegularFile(f"{path} is {link}{_kind(mode)}, not a regular file")
    fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    mode = os.fstat(fd).st_mode
    if not stat.S_ISREG(mode):
        os.close(fd)
        raise NotARegularFile(f"{path} is {_kind(mode)}, not a regular file")
    return os.fdopen(fd, "rb")


class UnreadableJSON(ValueError):
    """A file that does not parse as JSON; its message is the parser's reason."""


def read_json(path: str | os.PathLike, max_bytes: int | None = None):
    """Read the JSON value in the UTF-8 file ``path``.

    Raises `UnreadableJSON` for a path that is no regular file (`open_regular`), a file of
    more than ``max_bytes`` (default `MAX_JSON_BYTES`), bad UTF-8, bad syntax, an integer of
    more digits than Python converts, or nesting deeper than the parser's stack (100,000
    ``[`` raise RecursionError, which is no ValueError), so that each reader turns all into
    its own error.

    Parameters
    ----------
    path : path-like
        The JSON file.
    max_bytes : int, optional
        The most bytes read; `MAX_JSON_BYTES` when None.

    Returns
    -------
    object
        The parsed value.
    """
    limit = MAX_JSON_BYTES if max_bytes is None else max_bytes
    try:
        with open_regular(path) as f:
            data = f.read(limit + 1)  # not more, whatever the file grew to since
    except NotARegularFile as err:
        raise UnreadableJSON(str(err)) from err
    if len(data) > limit:
        raise UnreadableJSON(f"{path} holds more than the {limit} bytes read as JSON")
    try:
        return json.loads(data.decode("utf-8"))
    except (ValueError, RecursionError) as err:  # ValueError: bad JSON, UTF-8, huge integer
        raise UnreadableJSON(str(err)) from err


def write_json(path: str | os.PathLike, obj, indent: int = 2, finite: bool = False) -> None:
    """Write ``jsonable(obj, finite)`` as indented JSON with a final newline, atomically.

    Parameters
    ----------
    path : path-like
        The file to write.
    obj : object
        The value to write.
    indent : int, default 2
        Spaces per indentation level.
    finite : bool, default False
        Write NaN and infinities as null.
    """
    text = json.dumps(jsonable(obj, finite), indent=indent) + "\n"
    atomic_write_bytes(path, text.encode())


def write_png(path: str | os.PathLike, rgb: np.ndarray) -> Path:
    """Write an RGB ``(H, W, 3)`` uint8 image as a PNG atomically (its folder is created).

    Parameters
    ----------
    path : path-like
        The ``.png`` to write.
    rgb : ndarray of shape (H, W, 3), uint8
        The image.

    Returns
    -------
    Path
        ``path``.
    """
    import cv2  # only the writers of figures need OpenCV

    path = Path(path)
    ok, buf = cv2.imencode(".png", np.ascontiguousarray(np.asarray(rgb)[..., ::-1]))
    if not ok:
        raise RuntimeError(f"could not encode {path} as PNG")
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_bytes(path, buf.tobytes())
    return path

"""Reading an untrusted ``.npz`` without pickle, and without trusting what it says of itself.

``numpy.load`` trusts each member's header: a damaged or hand-made file can make it raise
``zlib.error``, ``AttributeError``, ``tokenize.TokenError`` or ``MemoryError`` (a header that
declares a huge shape). `read_arrays` checks every member before reading it (a plain
``name.npy``, once; a version 1 or 2 header; no Python objects; a declared size that matches the
member's size, which itself is bounded by its compressed size; at most `MAX_ARRAY_BYTES`
declared in all) and turns every failure into one `UnreadableNpz` that says what is
wrong.

Deflate packs a run of zeros about a thousand times, so a file of a few MB can hold members
that declare GiB, each a true size: `MAX_ARRAY_BYTES` (a module setting, 4 GiB) caps the
bytes of arrays one file may declare in all, checked on the headers before anything is
decompressed. A dataset sequence of 900 frames of 120x160 images holds about 60 MB.
"""

from __future__ import annotations

import re
import tokenize
import zipfile
import zlib
from pathlib import Path

import numpy as np

__all__ = ["MAX_ARRAY_BYTES", "UnreadableNpz", "read_arrays"]

# the bytes of arrays one file may declare in all (after decompression)
MAX_ARRAY_BYTES = 4 << 30

_MEMBER = re.compile(r"(?!.*\.\./)[A-Za-z0-9_][A-Za-z0-9_./-]{0,250}\.npy\Z")  # no "../"
_MAX_RATIO = 1100  # deflate expands at most ~1032 times; a member claiming more lies
_HEADER_READERS = {
    (1, 0): np.lib.format.read_array_header_1_0,
    (2, 0): np.lib.format.read_array_header_2_0,
}
_FAILURES = (  # what numpy and zipfile raise on damaged input
    zipfile.BadZipFile,
    zipfile.LargeZipFile,
    OSError,
    EOFError,
    zlib.error,
    ValueError,
    SyntaxError,
    tokenize.TokenError,
    TypeError,
    KeyError,
    AttributeError,
    OverflowError,
    NotImplementedError,
    RuntimeError,
    MemoryError,
    IndexError,
)


class UnreadableNpz(ValueError):
    """An ``.npz`` that is damaged, or holds something other than plain arrays."""


def _check_member(zf: zipfile.ZipFile, info: zipfile.ZipInfo, size: int) -> int:
    """Check one member's name, sizes and header; return the bytes of array it declares."""
    name = info.filename
    if not _MEMBER.match(name):
        raise UnreadableNpz(f"member {name!r} is not an array file ('name.npy', no '../')")
    if info.compress_size > size or info.file_size > max(info.compress_size, 1) * _MAX_RATIO:
        raise UnreadableNpz(f"member {name!r} claims sizes its file cannot hold")
    with zf.open(info) as f:
        version = np.lib.format.read_magic(f)
        if version not in _HEADER_READERS:
            raise UnreadableNpz(f"member {name!r} has .npy format version {version}")
        shape, _, dtype = _HEADER_READERS[version](f)
        if dtype.hasobject:
            raise UnreadableNpz(f"member {name!r} holds Python objects (dtype {dtype})")
        declared = int(np.prod(shape, dtype=object)) * dtype.itemsize
        if declared != info.file_size - f.tell():
            raise UnreadableNpz(
                f"member {name!r} declares shape {shape} of {dtype} ({declared} bytes) but "
                f"holds {info.file_size - f.tell()} bytes"
            )
    return declared


def read_arrays(path: str | Path) -> dict[str, np.ndarray]:
    """Read the arrays of the ``.npz`` at ``path`` by name (member name without ``.npy``).

    Parameters
    ----------
    path : str or Path
        The ``.npz`` file.

    Returns
    -------
    dict of str to ndarray
        Each member's array under its name without ``.npy``.

    Raises
    ------
    UnreadableNpz
        Saying what is wrong: not a zip file, a damaged member, a member that is not a plain
        ``.npy`` without Python objects, a name twice, a header that does not match the data,
        arrays of more than `MAX_ARRAY_BYTES` in all.
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        with zipfile.ZipFile(path) as zf:
            infos = zf.infolist()
            names = [info.filename for info in infos]
            twice = sorted({n for n in names if names.count(n) > 1})
            if twice:
                raise UnreadableNpz(f"members {twice} appear more than once")
            declared = sum(_check_member(zf, info, size) for info in infos)
            if declared > MAX_ARRAY_BYTES:
                raise UnreadableNpz(
                    f"its arrays declare {declared} bytes, more than MAX_ARRAY_BYTES = "
                    f"{MAX_ARRAY_BYTES}; raise common.npz.MAX_ARRAY_BYTES to read it"
                )
            arrays = {}
            for info in infos:
                with zf.open(info) as f:
                    arrays[info.filename[:-4]] = np.lib.format.read_array(f, allow_pickle=False)
            return arrays
    except UnreadableNpz:
        raise
    except _FAILURES as err:
        raise UnreadableNpz(f"{type(err).__name__}: {err}") from err

"""The plain-array messages between the evaluator and a policy's own process.

A message is a kind, a JSON object of plain values and named numeric arrays; nothing in it is
ever unpickled. On the wire (`encode`)::

    b"TMW1" | uint32 header length | header (UTF-8 JSON) | the arrays' bytes, one after another

with the header ``{"kind": str, "values": {...}, "arrays": [[name, dtype, shape], ...]}``. A
frame on the socket is an 8-byte big-endian length and the message (`send`,
`receive`). `decode` treats the bytes as untrusted: the magic, the lengths, the
JSON, every array's dtype (one of `DTYPES`, little-endian numbers only: no objects),
shape and size are checked, and any fault raises `WireError` saying which.
"""

from __future__ import annotations

import json
import select
import socket
import struct
import time

import numpy as np

MAGIC = b"TMW1"
DTYPES = ("|u1", "|i1", "|b1", "<i4", "<i8", "<f4", "<f8")  # plain numbers: no object, no void
MAX_HEADER = 1 << 20  # bytes of a header's JSON
MAX_ARRAYS = 256
MAX_DIMS = 8


class WireError(ValueError):
    """Bytes that are no message of this format; the text says what is wrong."""


class Closed(WireError):
    """The other end closed the connection (or its process died)."""


class Timeout(WireError):
    """No whole message came within the time allowed."""


def encode(kind: str, values: dict | None = None, arrays: dict | None = None) -> bytes:
    """Encode the message ``kind`` with the JSON-able ``values`` and the numeric ``arrays``.

    Each array's bytes are copied once, into the message.

    Parameters
    ----------
    kind : str
        The message's kind.
    values : dict, optional
        JSON-able values.
    arrays : dict of str to array_like, optional
        Numeric arrays, each of a dtype of `DTYPES` (big-endian ones are converted).

    Returns
    -------
    bytes or bytearray
        The message (a bytearray from 4096 bytes on).
    """
    specs, parts = [], []
    for name, a in (arrays or {}).items():
        a = np.ascontiguousarray(a)
        if a.dtype.byteorder == ">":
            a = a.astype(a.dtype.newbyteorder("<"))
        if a.dtype.str not in DTYPES:
            raise WireError(f"array {name!r}: dtype {a.dtype} is not one of {DTYPES}")
        specs.append([str(name), a.dtype.str, list(a.shape)])
        parts.append(a.reshape(-1).view(np.uint8))
    header = json.dumps({"kind": str(kind), "values": values or {}, "arrays": specs}).encode()
    out = bytearray(8 + len(header) + sum(p.size for p in parts))
    out[:4], out[4:8], out[8 : 8 + len(header)] = MAGIC, struct.pack("<I", len(header)), header
    at = 8 + len(header)
    for p in parts:
        out[at : at + p.size] = memoryview(p)
        at += p.size
    return bytes(out) if len(out) < 4096 else out


def decode(data: bytes | bytearray, max_bytes: int) -> tuple[str, dict, dict[str, np.ndarray]]:
    """Decode an untrusted message into ``(kind, values, arrays)``.

    The arrays are read-only views of ``data``. Raises `WireError` naming the fault.

    Parameters
    ----------
    data : bytes or bytearray
        The message.
    max_bytes : int
        The largest message accepted.

    Returns
    -------
    kind : str
        The message's kind.
    values : dict
        Its values.
    arrays : dict of str to ndarray
        Its arrays.
    """
    if len(data) > max_bytes:
        raise WireError(f"{len(data)} bytes, more than the {max_bytes} allowed")
    if len(data) < 8 or data[:4] != MAGIC:
        raise WireError(f"no {MAGIC.decode()} message (it starts {bytes(data[:8])!r})")
    (size,) = struct.unpack("<I", data[4:8])
    if size > min(MAX_HEADER, len(data) - 8):
        raise WireError(f"header of {size} bytes does not fit")
    try:
        header = json.loads(bytes(data[8 : 8 + size]).decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError) as err:
        raise WireError(f"header is not JSON ({type(err).__name__})") from None
    if not (isinstance(header, dict) and set(header) == {"kind", "values", "arrays"}):
        raise WireError("header must have exactly the keys kind, values and arrays")
    kind, values, specs = header["kind"], header["values"], header["arrays"]
    if not (isinstance(kind, str) and isinstance(values, dict) and isinstance(specs, list)):
        raise WireError("kind must be a string, values an object and arrays a list")
    if len(specs) > MAX_ARRAYS:
        raise WireError(f"{len(specs)} arrays, more than {MAX_ARRAYS}")
    arrays, offset = {}, 8 + size
    for spec in specs:
        name, dtype, shape = _array_spec(spec)
        if name in arrays:
            raise WireError(f"array {name!r} given twice")
        count = int(np.prod(shape, dtype=np.int64)) if shape else 1
        nbytes = count * np.dtype(dtype).itemsize
        if offset + nbytes > len(data):
            raise WireError(f"array {name!r} of shape {shape} runs past the message's end")
        a = np.frombuffer(data, dtype=dtype, count=count, offset=offset).reshape(shape)
        a.flags.writeable = False  # a view of the message, whatever buffer holds it
        arrays[name], offset = a, offset + nbytes
    if offset != len(data):
        raise WireError(f"{len(data) - offset} bytes after the last array")
    return kind, values, arrays


def _array_spec(spec) -> tuple[str, str, tuple[int, ...]]:
    if not (isinstance(spec, list) and len(spec) == 3):
        raise WireError(f"an array must be [name, dtype, shape], got {str(spec)[:80]}")
    name, dtype, shape = spec
    if not isinstance(name, str) or not 0 < len(name) <= 100:
        raise WireError("an array's name must be a string of 1 to 100 characters")
    if dtype not in DTYPES:
        raise WireError(f"array {name!r}: dtype {str(dtype)[:20]!r} is not one of {DTYPES}")
    if not (
        isinstance(shape, list)
        and len(shape) <= MAX_DIMS
        and all(isinstance(n, int) and not isinstance(n, bool) and 0 <= n < 1 << 40 for n in shape)
    ):
        raise WireError(f"array {name!r}: shape must be at most {MAX_DIMS} sizes >= 0")
    return name, dtype, tuple(shape)


def send(sock: socket.socket, message: bytes) -> None:
    """Write one frame (length, then ``message``).

    Raises `Closed` if the other end is gone.

    Parameters
    ----------
    sock : socket.socket
        The connected socket.
    message : bytes
        The message (`encode`).
    """
    try:  # the length, then the message itself: no copy of a large message
        sock.sendall(struct.pack(">Q", len(message)))
        sock.sendall(message)
    except OSError as err:  # BrokenPipe, ConnectionReset: the process died
        raise Closed(f"the connection closed ({type(err).__name__})") from None


def receive(sock: socket.socket, max_bytes: int, timeout: float | None = None) -> bytearray:
    """Read one frame's message, of at most ``max_bytes``, within ``timeout`` seconds.

    Raises `Timeout`, `Closed` or `WireError`.

    Parameters
    ----------
    sock : socket.socket
        The connected socket.
    max_bytes : int
        The largest message accepted.
    timeout : float, optional
        Seconds to wait; None: wait as long as it takes.

    Returns
    -------
    bytearray
        The message.
    """
    deadline = None if timeout is None else time.monotonic() + timeout
    head = _read(sock, 8, deadline)
    (size,) = struct.unpack(">Q", bytes(head))
    if size > max_bytes:
        raise WireError(f"a message of {size} bytes announced, more than the {max_bytes} allowed")
    return _read(sock, size, deadline)


def _read(sock: socket.socket, n: int, deadline: float | None) -> bytearray:
    buf = bytearray(n)
    view, got = memoryview(buf), 0
    while got < n:
        if deadline is not None:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([sock], [], [], left)[0]:
                raise Timeout("no answer in time")
        try:
            k = sock.recv_into(view[got:], n - got)
        except OSError as err:
            raise Closed(f"the connection failed ({type(err).__name__})") from None
        if k == 0:
            raise Closed("the other end closed the connection")
        got += k
    return buf

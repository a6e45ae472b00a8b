"""Seeded damage for the readers' fuzz tests: truncations, byte flips, field edits and special
numbers, and a per-case time budget (a hang fails the case instead of stalling the suite)."""

from __future__ import annotations

import contextlib
import gzip
import signal

import numpy as np

SPECIAL_TEXT = (
    "nan",
    "NaN",
    "inf",
    "-inf",
    "+inf",
    "1e308",
    "-1e308",
    "1e300",
    "1e6",
    "-1",
    "0",
    "-0",
    "1e-320",
    "99999999999999999999",
    "x",
    "",
    "0x10",
    "1_0",
    "\f",
    "\v",
    "\x1c",
    "9" * 400,
)
SPECIAL_NUMBERS = (np.nan, np.inf, -np.inf, 1e300, -1e300, -1.0, 0.0, 1e-320, 7.0, 1e7)


class OverBudget(Exception):
    """A case ran longer than its time budget."""


@contextlib.contextmanager
def budget(seconds: float):
    """Raise `OverBudget` in the main thread once ``seconds`` have passed."""

    def stop(signum, frame):
        raise OverBudget(f"over the budget of {seconds} s")

    previous = signal.signal(signal.SIGALRM, stop)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def truncated(data: bytes, rng: np.random.Generator) -> bytes:
    return data[: int(rng.integers(0, len(data)))]


def flipped(data: bytes, rng: np.random.Generator, flips: int = 1) -> bytes:
    out = bytearray(data)
    for _ in range(flips):
        out[int(rng.integers(len(out)))] ^= 1 << int(rng.integers(8))
    return bytes(out)


def field_edited(text: str, rng: np.random.Generator) -> str:
    """``text`` with one whitespace-separated field of one line replaced by a special value."""
    lines = text.split("\n")
    k = int(rng.integers(len(lines)))
    fields = lines[k].split(" ")
    fields[int(rng.integers(len(fields)))] = SPECIAL_TEXT[int(rng.integers(len(SPECIAL_TEXT)))]
    lines[k] = " ".join(fields)
    return "\n".join(lines)


def damaged_variants(text: str, rng: np.random.Generator, per_kind: int):
    """``(kind, bytes)`` of damaged copies of a text log, plain and gzip."""
    plain = text.encode()
    packed = gzip.compress(plain, mtime=0)
    for _ in range(per_kind):
        yield "truncated", truncated(plain, rng)
        yield "truncated gz", truncated(packed, rng)
        yield "flipped", flipped(plain, rng, int(rng.integers(1, 4)))
        yield "flipped gz", flipped(packed, rng, int(rng.integers(1, 4)))
        edited = field_edited(text, rng)
        yield "edited", edited.encode("ascii", "replace")
        yield "edited gz", gzip.compress(edited.encode("ascii", "replace"), mtime=0)

"""The readers' fuzz harness: seeded damage of every kind the readers must survive, and one
judge of each case's outcome.

Each reader's module builds small valid files, damages copies of them (truncation, byte
flips, odd JSON members and ``.npz`` arrays, huge integers, NaN and infinity, other dtypes,
shapes and ranks, sequences that disagree, links to ``/dev/zero``, named pipes, compression
bombs, ...) and recomputes every checksum after each edit, so that only the reader's own
checks stand between the damage and the caller. `Judge` then runs the reader on the
case within a time budget: the case passes when the reader raises its own error naming the
file, or returns what the judge's ``check`` accepts as physically possible and consistent;
a raw library exception, a hang or an accepted impossibility is an escape, and every escape
is listed when the test fails.

The default suite runs 320 cases in all; ``TOPOMAP_FUZZ_CASES=N`` runs ``N`` cases per reader
and per command instead (``TOPOMAP_FUZZ_CASES=500``: 2,500 cases over the five readers and
500 more through the map builder).
"""

from __future__ import annotations

import os
import shutil
import warnings
import zlib
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import numpy as np

from tests.sim.readers.fuzzing import OverBudget, budget, flipped, truncated

__all__ = [
    "ODD_VALUES",
    "SPECIAL_FILES",
    "Judge",
    "case_count",
    "flipped",
    "gz_bomb",
    "odd_array",
    "odd_member",
    "special_file",
    "truncated",
]

ENV = "TOPOMAP_FUZZ_CASES"
SPECIAL_FILES = ("pipe", "link to /dev/zero", "link to a pipe", "folder", "dangling link")
ODD_VALUES = (
    None,
    True,
    False,
    -1,
    0,
    2,
    1.5,
    10**400,
    -(10**400),
    1e308,
    -1e308,
    float("nan"),
    float("inf"),
    float("-inf"),
    "x",
    "",
    "9" * 400,
    [],
    [1, "a"],
    {},
    {"a": None},
    [[[[]]]],
    "../x.npz",
)


def case_count(default: int) -> int:
    """Cases per reader: ``default``, or the whole number in ``TOPOMAP_FUZZ_CASES``."""
    text = os.environ.get(ENV, "").strip()
    if not text:
        return default
    if not text.isdigit() or int(text) < 1:
        raise ValueError(f"{ENV} must be a positive whole number of cases, got {text!r}")
    return int(text)


def special_file(path: Path, kind: str) -> Path:
    """Put a special file of ``kind`` (one of `SPECIAL_FILES`) at ``path``."""
    if path.is_symlink() or path.is_file():
        path.unlink()
    elif path.is_dir():  # a ROS 2 bag's folder
        shutil.rmtree(path)
    if kind == "pipe":
        os.mkfifo(path)
    elif kind == "link to /dev/zero":
        path.symlink_to("/dev/zero")
    elif kind == "link to a pipe":
        os.mkfifo(path.with_name(path.name + ".fifo"))
        path.symlink_to(path.with_name(path.name + ".fifo"))
    elif kind == "folder":
        path.mkdir()
    else:
        path.symlink_to(path.with_name("nothing-here"))
    return path


def gz_bomb(size: int, line: bytes = b"# a comment\n") -> bytes:
    """A gzip stream of ``size`` bytes of ``line`` repeated (about 1 KB per MB)."""
    chunk = line * ((1 << 16) // len(line) + 1)
    comp = zlib.compressobj(9, zlib.DEFLATED, 31)  # wbits 31: a gzip header and trailer
    parts, left = [], size
    while left > 0:
        piece = chunk[: min(left, len(chunk))]
        parts.append(comp.compress(piece))
        left -= len(piece)
    parts.append(comp.flush())
    return b"".join(parts)


def odd_array(a: np.ndarray, rng: np.random.Generator) -> tuple[str, np.ndarray]:
    """``(what, array)``: ``a`` of another dtype, shape or rank, or holding special values."""
    kind = int(rng.integers(13))
    if kind == 0:
        return "empty", a[:0]
    if kind == 1:
        return "flattened", a.reshape(-1)
    if kind == 2:
        return "0-d", np.asarray(a.flat[0]) if a.size else np.asarray(0)
    if kind == 3:
        return "rank + 1", a[..., None]
    if kind == 4:
        with np.errstate(invalid="ignore"):
            return "complex", a.astype(np.complex64)
    if kind == 5:
        return "datetime", np.zeros(a.shape, "datetime64[s]")
    if kind == 6:
        return "text", a.astype("<U3")
    if kind == 7:
        return "bool", a.astype(bool)
    if kind == 8:
        big = np.iinfo(np.int64).max if a.dtype.kind in "iu" else np.inf
        return "huge", np.full(a.shape, big, a.dtype if a.dtype.kind in "iuf" else np.int64)
    if kind == 9:
        out = np.array(a, dtype=np.float64 if a.dtype.kind not in "f" else a.dtype)
        if out.size:
            with np.errstate(over="ignore"):  # 1e300 in float32 is inf
                out.flat[int(rng.integers(out.size))] = rng.choice([np.nan, -np.inf, 1e300, -1e300])
        return "special number", out
    if kind == 10:
        out = np.array(a, dtype=np.int64 if a.dtype.kind in "iub" else a.dtype)
        if out.size:
            out.flat[int(rng.integers(out.size))] = -3 if out.dtype.kind in "iu" else -1.0
        return "negative", out
    if kind == 11:
        return "one row more", np.concatenate([a, a[-1:]]) if a.ndim and len(a) else a
    with np.errstate(invalid="ignore", over="ignore"):
        return "other float", a.astype(np.float16 if a.dtype.kind == "f" else np.float32)


def odd_member(data, rng: np.random.Generator, values=ODD_VALUES) -> str:
    """Set one member of the JSON value ``data``, at any depth, to an odd value or delete it
    (in place); return its path (``"a.b.3"``)."""
    target, key, where = data, None, []
    while True:
        keys = list(range(len(target))) if isinstance(target, list) else sorted(target)
        if not keys:
            break
        key = keys[int(rng.integers(len(keys)))]
        where.append(str(key))
        if not isinstance(target[key], dict | list) or rng.random() < 0.3:
            break
        target = target[key]
    if key is None:
        return "nothing"
    if isinstance(target, dict) and rng.random() < 0.15:
        del target[key]
        return ".".join(where) + " deleted"
    target[key] = values[int(rng.integers(len(values)))]
    return ".".join(where)


class Judge:
    """Runs cases of one reader and records their outcomes.

    Parameters
    ----------
    load : callable
        ``load(path)``: the reader on the case at ``path``.
    error : type
        The reader's own error.
    check : callable
        ``check(result)``: asserts that what the reader returned is physically possible and
        consistent.
    seconds : float
        The time budget of one case; over it, the case is an escape (a hang).
    """

    def __init__(self, load: Callable, error: type, check: Callable, seconds: float = 5.0):
        self.load, self.error, self.check, self.seconds = load, error, check, seconds
        self.outcomes: Counter = Counter()
        self.escapes: list[str] = []

    def __call__(self, kind: str, path: Path, names: str | None = None) -> str:
        """Run the reader on ``path``; ``names``: what the error must name (default the
        path). Return ``"refused"``, ``"read"`` or ``"escaped"``."""
        outcome = "escaped"
        try:
            with budget(self.seconds), warnings.catch_warnings():
                warnings.simplefilter("ignore")  # the unusual is read with a warning
                result = self.load(path)
            self.check(result)
            outcome = "read"
        except OverBudget:
            self.escapes.append(f"{kind}: a hang (over {self.seconds} s)")
        except self.error as err:
            named = str(path if names is None else names)
            if named in str(err):
                outcome = "refused"
            else:
                self.escapes.append(f"{kind}: the error does not name {named}: {err}"[:400])
        except AssertionError as err:
            self.escapes.append(f"{kind}: accepted, but {err}"[:400])
        except Exception as err:  # what the fuzz looks for
            self.escapes.append(f"{kind}: {type(err).__name__}: {err}"[:400])
        self.outcomes[kind, outcome] += 1
        return outcome

    def summary(self) -> str:
        """One line per kind: how many cases were refused, read and escaped."""
        kinds = sorted({kind for kind, _ in self.outcomes})
        return "\n".join(
            f"{kind}: "
            + ", ".join(f"{o} {self.outcomes[kind, o]}" for o in ("refused", "read", "escaped"))
            for kind in kinds
        )

    def assert_clean(self, least: int) -> None:
        """Fail listing every escape, or when fewer than ``least`` cases ran."""
        total = sum(self.outcomes.values())
        print(self.summary())  # shown with pytest -s
        assert not self.escapes, f"{len(self.escapes)} of {total} cases escaped:\n" + "\n".join(
            self.escapes
        )
        assert total >= least, f"only {total} cases ran"

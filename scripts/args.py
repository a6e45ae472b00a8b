"""Argument types shared by the command-line parsers (``topomap`` and its subcommands): each
parses one string or raises ``argparse.ArgumentTypeError`` naming the expected form; and
`output_folder`, the check every ``--out`` gets before any work runs.
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

__all__ = [
    "frame_count",
    "non_negative_float",
    "non_negative_int",
    "output_folder",
    "policies",
    "positive_int",
    "world_choice",
    "worlds",
]

WORLD_HELP = "all (the canonical worlds), hallway, lawn or FAMILY:SEED such as hallway:17"


def _int_at_least(text: str, minimum: int) -> int:
    """``text`` as an integer >= ``minimum``; a ValueError for a non-integer (argparse then
    says "invalid ... value"), an ArgumentTypeError naming the bound for a smaller one.
    """
    value = int(text)
    if value < minimum:
        raise argparse.ArgumentTypeError(f"expected an integer >= {minimum}, got {text}")
    return value


def positive_int(text: str) -> int:
    """An integer >= 1."""
    return _int_at_least(text, 1)


def non_negative_int(text: str) -> int:
    """An integer >= 0, such as a seed (numpy refuses negative seeds)."""
    return _int_at_least(text, 0)


def frame_count(text: str) -> int:
    """Frames per sequence: an integer >= 2 (a sequence runs from its start to its end)."""
    return _int_at_least(text, 2)


def non_negative_float(text: str) -> float:
    """A finite number >= 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}") from None
    if not (value >= 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return value


def world_choice(text: str) -> str:
    """A ``--world`` value: ``all``, or a world name (``hallway``, ``lawn`` or
    ``FAMILY:SEED``), normalised (``hallway:0`` is ``hallway``); an ArgumentTypeError naming
    the accepted forms otherwise, which argparse prints as a usage error.
    """
    from scenes.families import check_world_name

    if text == "all":
        return text
    try:
        return check_world_name(text, "--world")
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"{err}; or 'all' for the canonical worlds") from None


def worlds(choice: str) -> tuple[str, ...]:
    """The worlds a ``--world`` choice names: one, or every world for ``all``."""
    from scenes import WORLDS

    return WORLDS if choice == "all" else (choice,)


def policies(text: str) -> tuple[str, ...]:
    """A comma-separated list of servo policies, each one of ``servo.task.policies.POLICIES``."""
    from servo.task import POLICIES

    names = tuple(n.strip() for n in text.split(",") if n.strip())
    bad = [n for n in names if n not in POLICIES]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown policies {bad}; choose from {POLICIES}")
    return names


def policy_name(text: str) -> str:
    """A servo policy: one of ``servo.task.policies.POLICIES`` or an outside factory
    ``package.module:factory`` (imported when the run starts, not here).
    """
    from servo.task import POLICIES

    if text in POLICIES:
        return text
    module, _, attr = text.partition(":")
    if not (module and attr.isidentifier() and all(p.isidentifier() for p in module.split("."))):
        raise argparse.ArgumentTypeError(
            f"expected one of {POLICIES} or package.module:factory, got {text!r}"
        )
    return text


def policy_arg(text: str) -> tuple[str, object]:
    """``KEY=VALUE``, a keyword argument of a policy's factory: the value as JSON if it reads
    as JSON (``3``, ``0.5``, ``true``, ``"text"``), else as the text itself.
    """
    import json

    key, sep, value = text.partition("=")
    if not sep or not key.isidentifier():
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE with KEY a name, got {text!r}")
    try:
        parsed = json.loads(value)
    except ValueError:
        parsed = value
    if isinstance(parsed, float) and not math.isfinite(parsed):
        raise argparse.ArgumentTypeError(f"{key} must be finite, got {value!r}")
    return key, parsed


def output_folder(value: str, option: str = "--out") -> Path:
    """The output folder ``value``, created now and probed for writing, so that a bad
    ``--out`` is reported before any work runs rather than after it (a servo evaluation
    writes its file only once every episode has run). Raises ValueError naming ``option``.
    """
    path = Path(value)
    if path.exists() and not path.is_dir():
        raise ValueError(f"{option} must be a folder, got the file {value}")
    try:
        path.mkdir(parents=True, exist_ok=True)
        # a probe file, not os.access: that says yes to root on a read-only mount
        tempfile.NamedTemporaryFile(dir=path, prefix=".write-test-").close()
    except OSError as err:
        reason = err.strerror or type(err).__name__
        raise ValueError(
            f"{option} must be a folder this user can create and write, got {value} ({reason})"
        ) from err
    return path

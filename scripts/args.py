"""Argument types shared by the command-line parsers (``topomap`` and its subcommands).

Each parses one string or raises ``argparse.ArgumentTypeError`` naming the expected form; and
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
    """Parse ``text`` as an integer >= ``minimum``.

    A ValueError for a non-integer (argparse then says "invalid ... value"), an
    ArgumentTypeError naming the bound for a smaller one.
    """
    value = int(text)
    if value < minimum:
        raise argparse.ArgumentTypeError(f"expected an integer >= {minimum}, got {text}")
    return value


def positive_int(text: str) -> int:
    """Parse an integer >= 1.

    Parameters
    ----------
    text : str
        The argument as given.

    Returns
    -------
    int
        The integer.
    """
    return _int_at_least(text, 1)


def non_negative_int(text: str) -> int:
    """Parse an integer >= 0, such as a seed (numpy refuses negative seeds).

    Parameters
    ----------
    text : str
        The argument as given.

    Returns
    -------
    int
        The integer.
    """
    return _int_at_least(text, 0)


def frame_count(text: str) -> int:
    """Parse frames per sequence: an integer >= 2 (a sequence runs from its start to its end).

    Parameters
    ----------
    text : str
        The argument as given.

    Returns
    -------
    int
        The frame count.
    """
    return _int_at_least(text, 2)


def non_negative_float(text: str) -> float:
    """Parse a finite number >= 0.

    Parameters
    ----------
    text : str
        The argument as given.

    Returns
    -------
    float
        The number.
    """
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}") from None
    if not (value >= 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return value


def world_choice(text: str) -> str:
    """Parse a ``--world`` value: ``all``, or a world name, normalised.

    A world name is ``hallway``, ``lawn`` or ``FAMILY:SEED``, normalised (``hallway:0`` is
    ``hallway``); an ArgumentTypeError naming the accepted forms otherwise, which argparse
    prints as a usage error.

    Parameters
    ----------
    text : str
        The argument as given.

    Returns
    -------
    str
        ``all`` or the normalised world name.
    """
    from scenes.families import check_world_name

    if text == "all":
        return text
    try:
        return check_world_name(text, "--world")
    except ValueError as err:
        raise argparse.ArgumentTypeError(f"{err}; or 'all' for the canonical worlds") from None


def worlds(choice: str) -> tuple[str, ...]:
    """Return the worlds a ``--world`` choice names: one, or every world for ``all``.

    Parameters
    ----------
    choice : str
        A value parsed by `world_choice`.

    Returns
    -------
    tuple of str
        The world names.
    """
    from scenes import WORLDS

    return WORLDS if choice == "all" else (choice,)


def policies(text: str) -> tuple[str, ...]:
    """Parse a comma-separated list of servo policies, each one of ``servo.task.policies.POLICIES``.

    Parameters
    ----------
    text : str
        The argument as given.

    Returns
    -------
    tuple of str
        The policy names, blanks dropped.
    """
    from servo.task import POLICIES

    names = tuple(n.strip() for n in text.split(",") if n.strip())
    bad = [n for n in names if n not in POLICIES]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown policies {bad}; choose from {POLICIES}")
    return names


def policy_name(text: str) -> str:
    """Parse a servo policy: one of ``servo.task.policies.POLICIES`` or an outside factory.

    An outside factory is ``package.module:factory`` (imported when the run starts, not here).

    Parameters
    ----------
    text : str
        The argument as given.

    Returns
    -------
    str
        ``text`` unchanged.
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
    """Parse ``KEY=VALUE``, a keyword argument of a policy's factory.

    The value is read as JSON if it reads as JSON (``3``, ``0.5``, ``true``, ``"text"``), else
    as the text itself.

    Parameters
    ----------
    text : str
        The argument as given.

    Returns
    -------
    tuple of (str, object)
        The key and the parsed value.
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
    """Create the output folder ``value`` now and probe it for writing.

    A bad ``--out`` is thus reported before any work runs rather than after it (a servo
    evaluation writes its file only once every episode has run).

    Parameters
    ----------
    value : str
        The folder as given.
    option : str, default "--out"
        The option's name, for the error message.

    Returns
    -------
    Path
        The folder.

    Raises
    ------
    ValueError
        If ``value`` is a file or a folder this user cannot create and write; it names
        ``option``.
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

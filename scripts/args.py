"""Argument types shared by the command-line parsers (``topomap`` and its subcommands): each
parses one string or raises ``argparse.ArgumentTypeError`` naming the expected form."""

from __future__ import annotations

import argparse

__all__ = ["non_negative_float", "policies", "positive_int", "worlds"]


def positive_int(text: str) -> int:
    """An integer >= 1."""
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected an integer >= 1, got {text}")
    return value


def non_negative_float(text: str) -> float:
    """A finite number >= 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}") from None
    if not (value >= 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(f"expected a finite number >= 0, got {text!r}")
    return value


def worlds(choice: str) -> tuple[str, ...]:
    """The worlds a ``--world`` choice names: one, or every world for ``all``."""
    from scenes import WORLDS

    return WORLDS if choice == "all" else (choice,)


def policies(text: str) -> tuple[str, ...]:
    """A comma-separated list of servo policies, each one of ``servo.evaluate.POLICIES``."""
    from servo.evaluate import POLICIES

    names = tuple(n.strip() for n in text.split(",") if n.strip())
    bad = [n for n in names if n not in POLICIES]
    if bad:
        raise argparse.ArgumentTypeError(f"unknown policies {bad}; choose from {POLICIES}")
    return names

"""Checks of scalar arguments shared across the layers, each raising an error that names the
parameter and the expected form.
"""

from __future__ import annotations

import difflib
import inspect
import math
from collections.abc import Iterable, Mapping
from numbers import Real

import numpy as np

__all__ = [
    "CheckedKeywords",
    "check_bool",
    "check_finite",
    "check_int",
    "check_keys",
    "check_keywords",
    "is_real",
]


def check_int(value, name: str, minimum: int = 1) -> int:
    """``value`` as an ``int``: a whole number (``3``, ``np.int64(3)`` or ``3.0``) at least
    ``minimum``; anything else raises ``ValueError`` naming ``name``.
    """
    try:
        whole = int(value) == value
    except (TypeError, ValueError, OverflowError):
        whole = False
    if not whole or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value}")
    return int(value)


def is_real(value) -> bool:
    """Whether ``value`` is a real number, numpy's included; not a bool (``np.bool_`` is no
    ``Real`` either) and not a string of digits. The test every scalar check here starts with;
    callers add their own range.
    """
    return isinstance(value, Real) and not isinstance(value, bool)


def check_finite(value, name: str) -> float:
    """``value`` as a ``float``: a finite real number (not a bool); else ``ValueError``."""
    if not is_real(value) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return float(value)


def check_bool(value, name: str) -> bool:
    """``value`` as a ``bool``: ``True`` or ``False`` (numpy's ``np.bool_`` too); anything else,
    ``1`` and ``"yes"`` included, raises ``ValueError`` naming ``name``.
    """
    if not isinstance(value, bool | np.bool_):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def check_keys(value, allowed: Iterable[str], name: str) -> dict:
    """``value`` as a dict whose keys are among ``allowed``: None gives ``{}``; a value that is
    no mapping raises ``TypeError``, an unknown key ``ValueError``, each naming ``name``, the
    allowed keys and, for a misspelt key, the closest one ("did you mean").
    """
    allowed = tuple(allowed)
    if value is None:
        return {}
    if not isinstance(value, Mapping):
        raise TypeError(
            f"{name} must be a dict with keys from {allowed} or None, got {type(value).__name__}"
        )
    for key in value:
        if key not in allowed:
            close = difflib.get_close_matches(str(key), allowed, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            raise ValueError(f"{name} has an unknown key {key!r} (known: {allowed}){hint}")
    return dict(value)


def check_keywords(func, args: tuple, kwargs: Mapping, name: str) -> None:
    """Refuse a call of ``func`` (a function or an ``__init__``, ``self`` first) with more
    positional arguments than it takes or a keyword it does not take, before it runs: a
    ``TypeError`` naming ``name`` (what is being made), the unknown keyword, the closest known
    one ("did you mean") and every keyword accepted. Python's own error names only the
    keyword, which says nothing of what to write instead.
    """
    params = list(inspect.signature(func).parameters.values())[1:]  # without self
    if any(p.kind is p.VAR_KEYWORD for p in params):
        return
    named = [p.name for p in params if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)]
    positional = [p.name for p in params if p.kind is p.POSITIONAL_OR_KEYWORD]
    if len(args) > len(positional) and not any(p.kind is p.VAR_POSITIONAL for p in params):
        raise TypeError(
            f"{name} takes at most {len(positional)} positional arguments "
            f"({', '.join(positional)}), got {len(args)}"
        )
    for key in kwargs:
        if key not in named:
            close = difflib.get_close_matches(str(key), named, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise TypeError(
                f"{name} got an unknown keyword {key!r}{hint}; it accepts: {', '.join(named)}"
            )


class CheckedKeywords:
    """A mixin that checks the keywords of a construction against ``__init__``'s before
    ``__init__`` runs ([`check_keywords`][common.validation.check_keywords]), so
    ``gym.make(env_id, camra=...)`` and ``Env(camra=...)`` alike name what is accepted.
    Put it first among the bases; it adds no state, and pickling is unchanged.
    """

    def __new__(cls, *args, **kwargs):
        check_keywords(cls.__init__, args, kwargs, cls.__name__)
        return super().__new__(cls)

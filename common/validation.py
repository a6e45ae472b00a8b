"""Checks of scalar arguments shared across the layers.

Each raises an error that names the parameter and the expected form.
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
    """Check that ``value`` is a whole number at least ``minimum`` and return it as an ``int``.

    A whole number is ``3``, ``np.int64(3)`` or ``3.0``; anything else raises ``ValueError``
    naming ``name``.

    Parameters
    ----------
    value : object
        The value to check.
    name : str
        The parameter's name, for the error.
    minimum : int, default 1
        The least value allowed.

    Returns
    -------
    int
        ``value`` as an ``int``.
    """
    try:
        whole = int(value) == value
    except (TypeError, ValueError, OverflowError):
        whole = False
    if not whole or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value}")
    return int(value)


def is_real(value) -> bool:
    """Check whether ``value`` is a real number, numpy's included.

    Not a bool (``np.bool_`` is no ``Real`` either) and not a string of digits. The test every
    scalar check here starts with; callers add their own range.

    Parameters
    ----------
    value : object
        The value to test.

    Returns
    -------
    bool
        True for a real number that is not a bool.
    """
    return isinstance(value, Real) and not isinstance(value, bool)


def check_finite(value, name: str) -> float:
    """Check that ``value`` is a finite real number (not a bool) and return it as a ``float``.

    Anything else raises ``ValueError`` naming ``name``.

    Parameters
    ----------
    value : object
        The value to check.
    name : str
        The parameter's name, for the error.

    Returns
    -------
    float
        ``value`` as a ``float``.
    """
    if not is_real(value) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return float(value)


def check_bool(value, name: str) -> bool:
    """Check that ``value`` is ``True`` or ``False`` (numpy's ``np.bool_`` too) and return it.

    Anything else, ``1`` and ``"yes"`` included, raises ``ValueError`` naming ``name``.

    Parameters
    ----------
    value : object
        The value to check.
    name : str
        The parameter's name, for the error.

    Returns
    -------
    bool
        ``value`` as a ``bool``.
    """
    if not isinstance(value, bool | np.bool_):
        raise ValueError(f"{name} must be True or False, got {value!r}")
    return bool(value)


def check_keys(value, allowed: Iterable[str], name: str) -> dict:
    """Check that ``value`` is a mapping whose keys are among ``allowed`` and return it as a dict.

    None gives ``{}``; a value that is no mapping raises ``TypeError``, an unknown key
    ``ValueError``, each naming ``name``, the allowed keys and, for a misspelt key, the closest
    one ("did you mean").

    Parameters
    ----------
    value : Mapping or None
        The value to check.
    allowed : iterable of str
        The keys allowed.
    name : str
        The parameter's name, for the error.

    Returns
    -------
    dict
        A copy of ``value``, or ``{}`` for None.
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
    """Refuse a call of ``func`` with arguments it does not take, before it runs.

    ``func`` is a function or an ``__init__``, ``self`` first. A call with more positional
    arguments than it takes or a keyword it does not take raises a ``TypeError`` naming
    ``name`` (what is being made), the unknown keyword, the closest known one ("did you mean")
    and every keyword accepted. Python's own error names only the keyword, which says nothing
    of what to write instead.

    Parameters
    ----------
    func : callable
        The function whose signature is checked; its first parameter is skipped.
    args : tuple
        The call's positional arguments, without ``self``.
    kwargs : Mapping
        The call's keyword arguments.
    name : str
        What is being made or called, for the error.
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
    """A mixin that checks the keywords of a construction against ``__init__``'s.

    The check runs before ``__init__`` does ([`check_keywords`][common.validation.check_keywords]),
    so ``gym.make(env_id, camra=...)`` and ``Env(camra=...)`` alike name what is accepted.
    Put it first among the bases; it adds no state, and pickling is unchanged.

    Parameters
    ----------
    *args, **kwargs
        The construction's arguments, checked against ``__init__``'s, then passed to it.
    """

    def __new__(cls, *args, **kwargs):
        """Check the keywords against ``__init__``'s, then create the instance."""
        check_keywords(cls.__init__, args, kwargs, cls.__name__)
        return super().__new__(cls)

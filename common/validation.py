"""Checks of scalar arguments shared across the layers, each raising an error that names the
parameter and the expected form."""

from __future__ import annotations

import math
from numbers import Real

__all__ = ["check_finite", "check_int", "is_real"]


def check_int(value, name: str, minimum: int = 1) -> int:
    """``value`` as an ``int``: a whole number (``3``, ``np.int64(3)`` or ``3.0``) at least
    ``minimum``; anything else raises ``ValueError`` naming ``name``."""
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
    callers add their own range."""
    return isinstance(value, Real) and not isinstance(value, bool)


def check_finite(value, name: str) -> float:
    """``value`` as a ``float``: a finite real number (not a bool); else ``ValueError``."""
    if not is_real(value) or not math.isfinite(value):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return float(value)

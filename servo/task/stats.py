"""Confidence intervals of the servo's success rates.

They are shared by the evaluation's summary and the benchmark protocol.
"""

from __future__ import annotations

import numpy as np

__all__ = ["WILSON_Z", "wilson_interval"]

WILSON_Z = 1.959963984540054  # two-sided 95%


def wilson_interval(successes: int, n: int, z: float = WILSON_Z) -> tuple[float, float]:
    """Return the Wilson score interval for a binomial rate (Wilson 1927).

    The closed form: ``(p + z^2/2n -+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n)``.

    Parameters
    ----------
    successes : int
        Successes, ``0 <= successes <= n``.
    n : int
        Trials, at least 1.
    z : float, default WILSON_Z
        The normal quantile (two-sided 95% by default).

    Returns
    -------
    tuple of float
        The interval's lower and upper bound, clipped to [0, 1].
    """
    if n < 1 or not 0 <= successes <= n:
        raise ValueError(f"need 0 <= successes <= n and n >= 1, got {successes}/{n}")
    p = successes / n
    denom = 1.0 + z * z / n
    centre = p + z * z / (2 * n)
    half = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return float(max(0.0, (centre - half) / denom)), float(min(1.0, (centre + half) / denom))

"""The physical bounds every reader checks a robot's data against, written down once.

A reader (Carmen logs, ROS bags, datasets) refuses a value outside these bounds with its own
error naming the file and where in it; the checks here only say what is wrong. The bounds are
deliberately wide: they catch what no robot can have recorded (a pose 10^308 m away, a range of
10^300 m, a NaN), never a real recording.

=================  ==========  ===========================================================
name               value       what it bounds
=================  ==========  ===========================================================
MAX_COORDINATE     1e6 m       ``|x|``, ``|y|`` of a pose or an odometry pose (1000 km)
MAX_HEADING        1e6 rad     ``|theta|`` of a pose (headings may be unwrapped)
MAX_RANGE          1e4 m       a finite laser reading, and a sensor's maximum range (10 km)
FULL_TURN          2 pi rad    a beam angle's ``|angle|``, a field of view, a beam spacing
MAX_SPEED          1e3         ``|v|`` (m/s) and ``|omega|`` (rad/s) of a command
MAX_TIME           1e10 s      ``|t|`` of a time stamp (Unix time of the year 2286)
=================  ==========  ===========================================================
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "FULL_TURN",
    "MAX_COORDINATE",
    "MAX_HEADING",
    "MAX_RANGE",
    "MAX_SPEED",
    "MAX_TIME",
    "angle_problem",
    "command_problem",
    "pose_problem",
    "range_problem",
    "time_problem",
]

MAX_COORDINATE = 1e6
MAX_HEADING = 1e6
MAX_RANGE = 1e4
FULL_TURN = 2 * math.pi
MAX_SPEED = 1e3
MAX_TIME = 1e10


def _first_bad(bad: np.ndarray) -> str:
    """``"row 3"`` (or ``"element (3, 1)"``) of the first True of ``bad``."""
    where = np.argwhere(bad)[0]
    return f"row {where[0]}" if bad.ndim == 1 else f"element {tuple(int(i) for i in where)}"


def _bounded(values, bound: float, what: str, unit: str) -> str | None:
    values = np.asarray(values, dtype=float)
    if not np.isfinite(values).all():
        if values.ndim == 0:
            return f"{what} {float(values)!r} is not finite"
        return f"{what} holds NaN or infinity (at {_first_bad(~np.isfinite(values))})"
    big = np.abs(values) > bound
    if big.any():
        if values.ndim == 0:
            return f"{what} {float(values)!r} is beyond the bound of {bound:g} {unit}"
        value = float(values[tuple(np.argwhere(big)[0])])
        return f"{what} {value!r} at {_first_bad(big)} is beyond the bound of {bound:g} {unit}"
    return None


def pose_problem(poses, what: str = "pose") -> str | None:
    """Say what is wrong with poses ``(..., 3)`` of ``(x, y, theta)``, or None.

    Each must be finite with ``|x|, |y| <= MAX_COORDINATE`` and ``|theta| <= MAX_HEADING``.

    Parameters
    ----------
    poses : array-like of shape (..., 3)
        ``(x, y, theta)`` poses.
    what : str, default "pose"
        What the poses are, for the message.

    Returns
    -------
    str or None
        The first problem found, or None.
    """
    poses = np.asarray(poses, dtype=float)
    return _bounded(poses[..., :2], MAX_COORDINATE, f"{what} position", "m") or _bounded(
        poses[..., 2], MAX_HEADING, f"{what} heading", "rad"
    )


def range_problem(ranges, what: str = "range") -> str | None:
    """Say what is wrong with laser readings, or None.

    No NaN, none negative, finite ones at most ``MAX_RANGE``; ``+inf`` (no return) is fine.

    Parameters
    ----------
    ranges : array-like
        Readings in metres.
    what : str, default "range"
        What the readings are, for the message.

    Returns
    -------
    str or None
        The first problem found, or None.
    """
    ranges = np.asarray(ranges, dtype=float)
    if np.isnan(ranges).any():
        return f"{what} holds NaN (at {_first_bad(np.isnan(ranges))})"
    if (ranges < 0).any():
        return f"negative {what} {float(ranges[ranges < 0][0])!r} (at {_first_bad(ranges < 0)})"
    big = np.isfinite(ranges) & (ranges > MAX_RANGE)
    if big.any():
        return (
            f"{what} {float(ranges[big][0])!r} (at {_first_bad(big)}) is beyond the bound of "
            f"{MAX_RANGE:g} m; a reading without a return is +inf or the sensor's maximum"
        )
    return None


def angle_problem(angles, what: str = "beam angle") -> str | None:
    """Say what is wrong with beam angles (radians), or None: finite, ``|angle| <= FULL_TURN``.

    Parameters
    ----------
    angles : array-like
        Beam angles in radians.
    what : str, default "beam angle"
        What the angles are, for the message.

    Returns
    -------
    str or None
        The first problem found, or None.
    """
    return _bounded(angles, FULL_TURN, what, "rad (a full turn)")


def command_problem(commands, what: str = "command") -> str | None:
    """Say what is wrong with commands ``(..., 2)`` of ``(v, omega)``, or None.

    Each must be finite and at most ``MAX_SPEED`` in size.

    Parameters
    ----------
    commands : array-like of shape (..., 2)
        ``(v, omega)`` commands in m/s and rad/s.
    what : str, default "command"
        What the commands are, for the message.

    Returns
    -------
    str or None
        The first problem found, or None.
    """
    return _bounded(commands, MAX_SPEED, what, "m/s or rad/s")


def time_problem(times, what: str = "time") -> str | None:
    """Say what is wrong with time stamps in recording order, or None.

    They must be finite, ``|t| <= MAX_TIME``, never going backwards (equal stamps are fine).

    Parameters
    ----------
    times : array-like
        Time stamps in seconds.
    what : str, default "time"
        What the stamps are, for the message.

    Returns
    -------
    str or None
        The first problem found, or None.
    """
    times = np.asarray(times, dtype=float)
    problem = _bounded(times, MAX_TIME, what, "s")
    if problem:
        return problem
    back = np.flatnonzero(np.diff(times) < 0)
    if back.size:
        k = int(back[0])
        return (
            f"{what} goes backwards at row {k + 1} ({float(times[k + 1])!r} after "
            f"{float(times[k])!r}); the "
            "frames must be in recording order"
        )
    return None

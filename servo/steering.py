"""The shared low-level control laws: pure pursuit toward a point and arrival at a pose.

Both take the goal *in the robot frame* (x ahead, y left), so the controller (which knows it
from scan matching) and the oracle (which knows it from the true pose) drive the same way and
differ only in what they know.
"""

from __future__ import annotations

from collections import deque

import numpy as np

from sim.simulator import CONTROL_DT, OMEGA_LIMIT, V_LIMITS

TURN_IN_PLACE = 0.8  # rad: a bearing beyond this is turned on the spot before driving
ARRIVE_RADIUS = 0.2  # m: position tolerance before the final turn (success needs 0.5 m)
ARRIVE_HEADING = 0.12  # rad: heading tolerance at the end (success needs 20 deg = 0.35 rad)
RESUME_RADIUS = 0.35  # m: hysteresis: a turning robot drives again only beyond this


def pursue(point: np.ndarray, speed: float) -> np.ndarray:
    """Return (v, omega) of pure pursuit toward ``point`` (robot frame): curvature 2 y / d^2.

    Parameters
    ----------
    point : ndarray of shape (2,)
        The point (x ahead, y left), m.
    speed : float
        Cruise speed, m/s.

    Returns
    -------
    ndarray of shape (2,)
        The command (v m/s, omega rad/s).
    """
    x, y = float(point[0]), float(point[1])
    bearing = np.arctan2(y, x)
    if abs(bearing) > TURN_IN_PLACE:
        return np.array([0.0, np.sign(bearing) * OMEGA_LIMIT * 0.8])
    d2 = max(x * x + y * y, 1e-6)
    curvature = 2.0 * y / d2
    v = speed * max(0.3, np.cos(bearing))
    if abs(curvature) * v > OMEGA_LIMIT:  # slow down rather than under-steer
        v = OMEGA_LIMIT / abs(curvature)
    return np.array([v, np.clip(curvature * v, -OMEGA_LIMIT, OMEGA_LIMIT)])


def turn_on_spot(err: float, turn_rate: float, dt: float) -> np.ndarray:
    """Return (0, omega) turning by ``err`` rad the short way.

    The rate is ``turn_rate``, slowed over the last step so as not to overshoot.

    Parameters
    ----------
    err : float
        The heading error, rad.
    turn_rate : float
        The turn rate, rad/s.
    dt : float
        The control step, s.

    Returns
    -------
    ndarray of shape (2,)
        The command (0, omega rad/s).
    """
    return np.array([0.0, np.sign(err) * min(turn_rate, abs(err) / dt)])


def pursue_route(
    goal: np.ndarray, reverse: bool, speed: float, careful: bool, turn_rate: float
) -> np.ndarray:
    """Return (v, omega) of `pursue` toward ``goal`` (robot frame), forward or in reverse.

    Reversing is pursuit of the goal mirrored through the robot (the robot turned round) with
    the speed's sign flipped; the turn rate is the same. ``careful`` (just backed off a wall,
    which stops a turn as well as a drive, so pursuit would drive into it turning): face the
    goal on the spot first, at ``turn_rate``, then drive at half speed.

    Parameters
    ----------
    goal : ndarray of shape (2,)
        The goal (x ahead, y left), m.
    reverse : bool
        Drive in reverse.
    speed : float
        Cruise speed, m/s.
    careful : bool
        Face the goal on the spot first, then drive at half speed.
    turn_rate : float
        The turn rate on the spot, rad/s.

    Returns
    -------
    ndarray of shape (2,)
        The command (v m/s, omega rad/s).
    """
    sign = -1.0 if reverse else 1.0
    goal = sign * np.asarray(goal, np.float64)
    if careful:
        bearing = float(np.arctan2(goal[1], goal[0]))
        if abs(bearing) > 0.3:
            return np.array([0.0, np.sign(bearing) * turn_rate])
        speed *= 0.5
    v, omega = pursue(goal, speed)
    return np.array([sign * v, omega])


class Arrival:
    """Drive to a pose, then turn to its heading; ``done`` once within tolerance.

    A two-stage law with hysteresis: position first (slowing with distance), then the heading
    on the spot, resuming the drive only if the position error grows past ``RESUME_RADIUS``.

    Parameters
    ----------
    radius : float, default ARRIVE_RADIUS
        Position tolerance, m, in (0, ``RESUME_RADIUS``).
    """

    def __init__(self, radius: float = ARRIVE_RADIUS) -> None:
        if not 0 < radius < RESUME_RADIUS:
            raise ValueError(f"radius must be in (0, {RESUME_RADIUS}) m, got {radius}")
        self.radius = float(radius)
        self.turning = False
        self.done = False

    def __call__(self, goal: np.ndarray) -> np.ndarray:
        """Return the command toward ``goal``, the target pose (x, y, yaw) in the robot frame."""
        d = float(np.hypot(goal[0], goal[1]))
        if d > (RESUME_RADIUS if self.turning else self.radius):
            self.turning = self.done = False
            bearing = np.arctan2(goal[1], goal[0])
            if d < 0.6 and abs(bearing) > np.pi / 2:  # just past it: back up, do not circle
                return np.array([max(V_LIMITS[0], -0.8 * d), -1.5 * np.sin(bearing) * 0.5])
            return pursue(goal[:2], min(0.8, 0.2 + 0.8 * d))
        self.turning = True
        e = float(goal[2])
        if abs(e) <= ARRIVE_HEADING:
            self.done = True
            return np.zeros(2)
        self.done = False
        return np.array([0.0, np.sign(e) * np.clip(1.5 * abs(e), 0.25, 1.0)])


class StallWindow:
    """Commanded motion that odometry does not see.

    Over the last ``steps`` steps the net odometry displacement is below a quarter of the
    commanded distance (a robot pushing a wall jitters in place, and its per-step distances
    summed would look like motion).

    Parameters
    ----------
    steps : int
        The window's length, steps.
    """

    def __init__(self, steps: int):
        self._moves: deque = deque(maxlen=int(steps))

    def clear(self) -> None:
        """Empty the window."""
        self._moves.clear()

    def stalled(self, speed: float, odometry) -> bool:
        """Add a step and tell whether the window is full and shows a stall.

        Parameters
        ----------
        speed : float
            The commanded speed, m/s.
        odometry : array_like of shape (3,)
            The odometry pose (x, y, yaw) after the step.

        Returns
        -------
        bool
            True on a stall.
        """
        self._moves.append((abs(float(speed)), float(odometry[0]), float(odometry[1])))
        if len(self._moves) < self._moves.maxlen:
            return False
        m = np.array(self._moves)
        commanded = m[:, 0].sum() * CONTROL_DT
        moved = float(np.hypot(*(m[-1, 1:3] - m[0, 1:3])))
        return bool(commanded > 0.02 * len(m) and moved < 0.25 * commanded)

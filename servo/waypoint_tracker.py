"""``WaypointTracker``: which waypoint view a view-sequence navigator servoes to.

It advances when F^j(k) toward the next waypoint overtakes F toward the current one (Section
II-G's signal used as in view-sequence navigation); shared by
[`SignalServo`][servo.camera_only.controller.SignalServo] and the greedy F-probing baseline
(`servo.task.baseline_policies`).
"""

from __future__ import annotations

import numpy as np


class WaypointTracker:
    """Which waypoint view the robot is servoing to.

    The current one until F toward the next overtakes it (or, where both are 0, the next one
    aligns better), or until the robot has driven well past the distance the map puts between
    them.

    Parameters
    ----------
    waypoints : list of int
        The waypoint views, in order (not empty).
    directions : ndarray
        Each waypoint's direction of travel (+1 or -1).
    gaps : ndarray
        The distance the map puts before each waypoint's successor, m.
    overrun : float
        Moves on when the robot has driven more than ``overrun`` times the gap plus 0.5 m.
    """

    def __init__(
        self, waypoints: list[int], directions: np.ndarray, gaps: np.ndarray, overrun: float
    ):
        if not len(waypoints) == len(directions) == len(gaps) or not waypoints:
            raise ValueError("waypoints, directions and gaps must be equally long, not empty")
        self.waypoints, self.directions, self.gaps = list(waypoints), directions, gaps
        self.overrun = float(overrun)
        self.index = 0
        self.driven = 0.0  # m since the current waypoint became current

    @property
    def current(self) -> int:
        """The waypoint view servoed to."""
        return self.waypoints[self.index]

    @property
    def next(self) -> int | None:
        """The waypoint view after it (None at the last)."""
        return self.waypoints[self.index + 1] if self.index + 1 < len(self.waypoints) else None

    @property
    def last(self) -> bool:
        """Whether the current waypoint is the last."""
        return self.index == len(self.waypoints) - 1

    def update(
        self, f_current: float, f_next: float, d_current: float, d_next: float, moved: float
    ) -> bool:
        """Advance if the next waypoint has overtaken the current one.

        Parameters
        ----------
        f_current, f_next : float
            F toward the current and the next waypoint.
        d_current, d_next : float
            How well each aligns (compared where both F are 0: the smaller wins).
        moved : float
            Metres driven since the last update.

        Returns
        -------
        bool
            True if it advanced.
        """
        self.driven += moved
        if self.last:
            return False
        overtaken = f_next > f_current if max(f_next, f_current) > 0 else d_next < d_current
        overrun = self.driven > self.overrun * self.gaps[self.index] + 0.5
        if overtaken or overrun:
            self.advance()
            return True
        return False

    def advance(self) -> None:
        """Move on to the next waypoint (reached by other means than F)."""
        if not self.last:
            self.index += 1
            self.driven = 0.0

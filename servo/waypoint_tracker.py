"""``WaypointTracker``: which waypoint view a view-sequence navigator servoes to, advancing when
F^j(k) toward the next waypoint overtakes F toward the current one (Section II-G's signal used
as in view-sequence navigation); shared by [`SignalServo`][servo.camera_only.controller.SignalServo]
and the greedy F-probing baseline (`servo.task.baseline_policies`).
"""

from __future__ import annotations

import numpy as np


class WaypointTracker:
    """Which waypoint view the robot is servoing to: the current one until F toward the next
    overtakes it (or, where both are 0, the next one aligns better), or until the robot has
    driven well past the distance the map puts between them.
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
        return self.waypoints[self.index]

    @property
    def next(self) -> int | None:
        return self.waypoints[self.index + 1] if self.index + 1 < len(self.waypoints) else None

    @property
    def last(self) -> bool:
        return self.index == len(self.waypoints) - 1

    def update(
        self, f_current: float, f_next: float, d_current: float, d_next: float, moved: float
    ) -> bool:
        """Advance if the next waypoint has overtaken the current one; True if it did."""
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

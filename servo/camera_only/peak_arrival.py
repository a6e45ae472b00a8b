"""Arrive at a stored view at the peak of F^j(k) toward it.

Section II-G: F toward a view is largest at the view. The arrival of
[`SignalServo`][servo.camera_only.controller.SignalServo].

`PeakArrival` works on the robot's belief in the route frame
(`RouteBelief`) and corrects it by where F peaks:

1. *Face the view.* Facing away (a recording driven backwards), the arrival law on the belief
   brings the robot to the view's place and turns it to the view's heading.
2. *Sweep its line of sight.* Forward ``overshoot`` m past the view, then back and forth, each
   leg longer, keeping the view's heading (`line_drive`), until F has peaked above
   ``arrive_confirm`` and fallen by ``arrive_drop``: the peak was at the view, so the belief is
   moved along the line to make it so; the arrival law drives back to it.
3. *Probe across.* Settled, F is read there and ``lateral`` m to either side (the arrival law
   to each); where a side gives more F, the view lies that way: the belief is moved across and
   the sweep starts again (at most ``lateral_rounds`` times). Otherwise the robot is done.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from common.geometry import se2_relative, wrap_angle
from servo.camera_only.config import SignalServoConfig
from servo.camera_only.route_belief import RouteBelief
from servo.steering import Arrival


def line_drive(goal: np.ndarray) -> np.ndarray:
    """Return (v, omega) toward ``goal`` along the robot's heading.

    ``goal`` is (x, y, yaw) in the robot frame; the robot drives forward or backward and never
    turns away from the goal's heading (the camera keeps facing the way the target view looks).

    Parameters
    ----------
    goal : numpy.ndarray
        The goal (x, y, yaw) in the robot frame (m, m, rad).

    Returns
    -------
    numpy.ndarray
        The command (v, omega), m/s and rad/s.
    """
    v = float(np.clip(1.2 * goal[0], -0.45, 0.6))
    v = float(np.sign(goal[0])) * max(abs(v), 0.2)
    omega = float(np.clip(2.0 * goal[2] + 1.0 * goal[1] * np.sign(v), -1.0, 1.0))
    return np.array([v, omega])


class PeakArrival:
    """The arrival at the target view by the F peak (see the module doc).

    ``step(belief, target, signal)``: ``target`` is the view's pose in the route frame and
    ``signal()`` returns F toward it for the current image (called only when it is needed).
    ``stage``: "face", "sweep", "settle", "probe" or "done". ``swept_peak``: None, or the
    largest F of the last whole sweep (every leg) that never reached ``arrive_min``.

    Parameters
    ----------
    config : SignalServoConfig
        The controller's settings (``overshoot``, ``sweeps``, ``arrive_confirm``,
        ``arrive_drop``, ``lateral``, ``lateral_rounds`` and the like).
    """

    def __init__(self, config: SignalServoConfig):
        self.config = config
        self.stage = "face"
        self._arrival = Arrival()
        self._leg, self._legs = 1, 0  # sweep direction along the view's sight, legs done
        self._peak, self._peak_along = 0.0, 0.0
        self._probe: list[float] = []  # F at the centre, then at each side probed
        self._rounds = 0
        # F's peak over the last whole sweep that ended without one (below ``arrive_min``)
        self.swept_peak: float | None = None

    @property
    def done(self) -> bool:
        """Whether the robot has arrived (``stage`` "done")."""
        return self.stage == "done"

    def step(
        self,
        belief: RouteBelief,
        target: np.ndarray,
        signal: Callable[[], float],
    ) -> np.ndarray:
        """Return the command for this step.

        Parameters
        ----------
        belief : RouteBelief
            The robot's pose on the route; moved where F's peak places the view.
        target : numpy.ndarray
            The target view's pose (x, y, yaw) in the route frame.
        signal : callable
            Returns F toward the target for the current image; called only when needed.

        Returns
        -------
        numpy.ndarray
            The command (v, omega).
        """
        c, b = self.config, belief
        u = np.array([np.cos(target[2]), np.sin(target[2])])
        left = np.array([-u[1], u[0]])
        facing = abs(wrap_angle(target[2] - b.pose[2])) < c.facing
        if self.stage == "face" or (self.stage == "sweep" and not facing):
            self.stage = "sweep" if facing else "face"
            if not facing:
                return self._arrival(se2_relative(b.pose, target))
        if self.stage == "sweep":
            return self._sweep(b, target, u, signal())
        if self.stage in ("settle", "probe"):
            return self._settle(b, target, left, signal)
        return self._arrival(se2_relative(b.pose, target))  # done: hold (or correct) the pose

    def _sweep(self, b: RouteBelief, target: np.ndarray, u: np.ndarray, f: float) -> np.ndarray:
        c = self.config
        along = float(u @ (b.pose[:2] - target[:2]))  # m past the view, by the belief
        if f > self._peak:
            self._peak, self._peak_along = f, along
        end, at_end = self._leg_end(along)
        # F toward a view is not monotonic along its sight (a door or a tree can give a
        # secondary peak a metre out): a peak counts once F has fallen well below it and
        # the robot has gone on a good way past it
        beyond = (along - self._peak_along) * self._leg > c.arrive_past
        peaked = self._peak >= c.arrive_confirm and f < c.arrive_drop * self._peak and beyond
        swept = at_end and self._legs >= c.sweeps - 1  # the sweep's last leg is done
        if peaked or (swept and self._peak >= c.arrive_min):
            # the peak was at the view
            b.pose[:2] -= u * self._peak_along
            self.stage, self._arrival, self._probe = "settle", Arrival(), []
            return self._arrival(se2_relative(b.pose, target))
        if swept:
            self.swept_peak = self._peak
        if at_end:
            self._leg, self._legs = -self._leg, (self._legs + 1) % c.sweeps
        goal = target.copy()
        goal[:2] += u * end
        return line_drive(se2_relative(b.pose, goal))

    def _leg_end(self, along: float) -> tuple[float, bool]:
        """Find where the sweep's current leg ends and whether the robot has reached it.

        The end is in m along the view's sight (each leg longer than the last); the robot is
        ``along`` m past the view.
        """
        end = self._leg * self.config.overshoot * (1.0 + 0.5 * self._legs)
        return end, (along - end) * self._leg > -0.1

    def _settle(
        self, b: RouteBelief, target: np.ndarray, left: np.ndarray, signal: Callable[[], float]
    ) -> np.ndarray:
        """Drive to the view's place, then F there and ``lateral`` m to either side."""
        c = self.config
        offsets = (0.0, c.lateral, -c.lateral)
        goal = target.copy()
        goal[:2] += offsets[len(self._probe)] * left
        action = self._arrival(se2_relative(b.pose, goal))
        if not self._arrival.done:
            return action
        if self._rounds >= c.lateral_rounds:
            self.stage = "done"
            return action
        self.stage = "probe"
        self._probe.append(signal())
        if len(self._probe) < len(offsets):
            self._arrival = Arrival()
            return action
        k = int(np.argmax(self._probe))
        self._rounds += 1
        if k == 0 or self._probe[k] <= self._probe[0]:
            self.stage, self._arrival = "done", Arrival()
            return action
        # the view lies toward the side that gave more F: sweep again there
        b.pose[:2] -= offsets[k] * left
        self._restart()
        return action

    def _restart(self) -> None:
        """Sweep the view's line of sight again (a new round)."""
        self.stage, self._arrival = "sweep", Arrival()
        self._leg, self._legs, self._peak = 1, 0, 0.0
        self._peak_along = 0.0

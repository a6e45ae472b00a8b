"""Looking back on a route driven turned round.

For [`SignalServo`][servo.camera_only.controller.SignalServo]. Where a route runs a recording
backwards and the map's parallax is too small for the reverse-stable fix (the lawn:
``reverse_parallax``), the robot turns round and drives forward, its camera facing away from the
way the stored views look: no image fix is possible, and odometry alone carries the belief for
up to 20 m. A heading error of 0.1-0.2 rad there puts the robot 2-4 m beside the target view
when the arrival begins, where the sweep along the view's sight never meets F's peak (dev: 5 of
the lawn's 17 `view` failures on episodes 0-79 arrived facing back along a recording, 2.2-4.8 m
from the target view).

`LookBack` stops every ``look_back`` m of such driving, turns on the spot to face the
way the views look, stands for ``look_steps`` steps while the controller takes its ordinary
image and pose fixes (heading, the position along the matched view's sight, the offset across
it), then turns back and drives on. Two half turns per look (~5 s at 1.2 rad/s). Measured
(docs/guides/servo.md): dev `view` +6 / -1 of 80, test +7 / -4 over the lawn's three cells.
"""

from __future__ import annotations

import numpy as np

from common.geometry import wrap_angle
from servo.steering import turn_on_spot

__all__ = ["LookBack"]


class LookBack:
    """Turn to ``heading`` + pi (route frame), stand ``steps`` steps, turn back to ``heading``.

    ``step(belief, dt)`` returns the command, or None once facing ``heading`` again;
    ``fixing`` says whether this step is one of the standing steps (the caller's image fixes
    run then). The belief's heading follows odometry through the turns and the fixes correct
    it, so the turn back aims at the route's way as the fixes now see it.

    Parameters
    ----------
    heading : float
        The route's way in the route frame, rad: the robot faces it again after the look.
    steps : int
        The steps to stand facing ``heading`` + pi.
    turn_rate : float
        The turn rate, rad/s.
    """

    def __init__(self, heading: float, steps: int, turn_rate: float):
        self.heading, self.steps, self.turn_rate = float(heading), int(steps), float(turn_rate)
        self.stage = "turn"
        self.fixing = False
        self._stood = 0

    def step(self, belief, dt: float) -> np.ndarray | None:
        """Return the command for this step, or None once facing ``heading`` again.

        Parameters
        ----------
        belief : RouteBelief
            The robot's pose on the route; its heading steers the turns.
        dt : float
            The control step, s.

        Returns
        -------
        numpy.ndarray or None
            The command (v, omega); None when the look is over.
        """
        h = float(belief.pose[2])
        self.fixing = False
        if self.stage == "turn":
            action = self._turn(wrap_angle(self.heading + np.pi - h), dt)
            if action is not None:
                return action
            self.stage = "stand"
        if self.stage == "stand":
            if self._stood < self.steps:
                self._stood += 1
                self.fixing = True
                return np.zeros(2)
            self.stage = "back"
        return self._turn(wrap_angle(self.heading - h), dt)

    def _turn(self, err: float, dt: float) -> np.ndarray | None:
        return None if abs(err) <= 0.05 else turn_on_spot(err, self.turn_rate, dt)

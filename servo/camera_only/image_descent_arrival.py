"""Arrive at a stored view by descending the image distance to it, for
[`SignalServo`][servo.camera_only.controller.SignalServo] with ``arrive_descent``.

F^j(k) toward a view (eq. 13) is computed on the image as it is, so it falls with the
heading as much as with the place: rendered around eight lawn views facing their heading
give or take 0.1 rad, F at the view itself was below 0.2 at five of them, and a metre or
more away its median was 0.00-0.04 at seven. The image's distance to the view minimised
over horizontal shifts (`align`: the heading taken
out) is the translational image difference function of visual homing (Zeil, Hofmann &
Chahl 2003, "Catchment areas of panoramic snapshots in outdoor scenes"): greedy descent on
it over a 0.5 m grid reached the view from 86-100 % of the points 2-3 m off at five of the
eight views, and 1 m across toward the view it was below 1 m away from it at 88-100 % of
the points at seven of them (``experiments/servo/arrival_descent.py``; docs/guides/servo.md).
Along the view's sight its least lies up to 0.5 m off, where F's peak, when it is seen,
does not.
`DescentArrival` is `PeakArrival` (the F peak on the
view's line of sight, probed across) until a sweep finds no F at all:

1. *Sweep* the view's line of sight as `PeakArrival` does,
   also reading the distance. Where F has stayed below ``arrive_min`` and the distance has a
   least inside the line swept, risen by ``descent_rise`` of it a good way past it (or a
   sweep there and back is done: far beside the view the distance is flat along the line),
   the robot is off the view's sight (the peak of F is sharp across it).
2. *Search across* from that least: the distance is read ``descent_step`` m to one side (the
   arrival law to the point, ending with the view's heading), then on that way while it
   falls, else on the other side; once the least reading has a reading either side, a
   parabola through the three puts the view across and the belief is moved to put it there.
   A point the robot cannot reach (a bump) reads as no match.
3. Sweep again (the F peak, 1.), the next search with half the step (not below
   ``MIN_STEP``), at most ``descent_rounds`` searches.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from common.geometry import se2_relative
from servo.camera_only.config import SignalServoConfig
from servo.camera_only.peak_arrival import PeakArrival
from servo.camera_only.route_belief import RouteBelief
from servo.steering import Arrival

MIN_STEP = 0.3  # m: a probe step below this no longer tells sides apart (success: 0.5 m)
RISE_FLOOR = 0.01  # squared-distance units: a rise smaller than this is noise
SEARCH_WIDTH = 3.0  # m either side of the route's end the search across goes at most


def parabola_vertex(left: float, centre: float, right: float, step: float) -> float:
    """Where, across (m, left positive), the distance read at ``-step`` (``right``), ``0``
    (``centre``) and ``+step`` (``left``) is least by the parabola through the three; where
    they do not curve up, the lower side; within ``1.5 step`` of the centre.
    """
    curve = left - 2.0 * centre + right
    if curve > 1e-12:
        offset = 0.5 * step * (right - left) / curve
    else:
        offset = step * np.sign(right - left) * 1.5
    return float(np.clip(offset, -1.5 * step, 1.5 * step))


class DescentArrival(PeakArrival):
    """`PeakArrival` that searches across by the image
    distance where a sweep finds no F (see the module doc).

    ``step(belief, target, signal, distance)``: as `PeakArrival.step`, and
    ``distance()`` the current image's shift-minimised distance to the target view.
    ``stage`` may also be "across" (searching); ``searches``: searches begun.
    """

    def __init__(self, config: SignalServoConfig):
        super().__init__(config)
        self._step = float(config.descent_step)
        self.searches = 0
        self._distance: Callable[[], float] | None = None
        self._line_start()

    def _line_start(self) -> None:
        self._least, self._least_along = np.inf, 0.0
        self._seen = (np.inf, -np.inf)  # the span of the line swept (m along)

    def _restart(self) -> None:
        super()._restart()
        self._line_start()

    def blocked(self) -> None:
        """The robot bumped: while searching across, the point it was driving to reads as no
        match (the search turns the other way).
        """
        if self.stage == "across" and self._next is not None:
            self._read[self._next] = np.inf
            self._next = self._choose()
            self._arrival = Arrival()

    def step(
        self,
        belief: RouteBelief,
        target: np.ndarray,
        signal: Callable[[], float],
        distance: Callable[[], float] | None = None,
    ) -> np.ndarray:
        if distance is None:
            raise ValueError("DescentArrival.step needs distance(), the image's distance")
        self._distance = distance
        if self.stage == "across":
            left = np.array([-np.sin(target[2]), np.cos(target[2])])
            return self._search(belief, target, left)
        return super().step(belief, target, signal)

    def _sweep(
        self, b: RouteBelief, target: np.ndarray, u: np.ndarray, left: np.ndarray, f: float
    ) -> np.ndarray:
        c = self.config
        d = self._distance()
        along = float(u @ (b.pose[:2] - target[:2]))  # m past the view, by the belief
        if d < self._least:
            self._least, self._least_along = d, along
        self._seen = (min(self._seen[0], along), max(self._seen[1], along))
        beyond = (along - self._least_along) * self._leg > c.arrive_past
        risen = d > self._least * (1.0 + c.descent_rise) + RISE_FLOOR
        # the least inside the line swept, not where the sweep began (moving away from it)
        inside = self._seen[0] + 0.1 < self._least_along < self._seen[1] - 0.1
        unseen = max(self._peak, f) < c.arrive_min  # no F anywhere on this line
        # far beside the view the distance is flat along the line: a sweep there and back
        swept = self._leg_end(along)[1] and self._legs >= min(1, c.sweeps - 1)
        if ((beyond and risen) or swept) and inside and unseen and self.searches < c.descent_rounds:
            b.pose[:2] -= u * self._least_along  # search across where the distance was least
            self.searches += 1
            self._read = {0.0: self._least}
            self._next = self._step * (1.0 if self.searches % 2 else -1.0)
            self.stage, self._arrival = "across", Arrival()
            return self._arrival(se2_relative(b.pose, target))
        return super()._sweep(b, target, u, left, f)

    def _choose(self) -> float | None:
        """The next point across to read, or None where the least reading has readings on
        both sides (or the search has gone ``SEARCH_WIDTH`` m).
        """
        best = min(self._read, key=self._read.get)
        for side in (1.0, -1.0) if best >= 0 else (-1.0, 1.0):
            o = round(best + side * self._step, 6)
            if o not in self._read and abs(o) <= SEARCH_WIDTH:
                return o
        return None

    def _search(self, b: RouteBelief, target: np.ndarray, left: np.ndarray) -> np.ndarray:
        if self._next is None:  # the last point was not reached (`blocked`)
            return self._searched(b, target, left)
        goal = target.copy()
        goal[:2] += self._next * left
        action = self._arrival(se2_relative(b.pose, goal))
        if not self._arrival.done:
            return action
        self._read[self._next] = self._distance()
        self._arrival = Arrival()
        self._next = self._choose()
        return action if self._next is not None else self._searched(b, target, left)

    def _searched(self, b: RouteBelief, target: np.ndarray, left: np.ndarray) -> np.ndarray:
        """Move the belief to put the view across where the readings say; sweep again."""
        best = min(self._read, key=self._read.get)
        sides = [self._read.get(round(best + s * self._step, 6), np.inf) for s in (1.0, -1.0)]
        across = best
        if np.isfinite(sides).all():
            across += parabola_vertex(sides[0], self._read[best], sides[1], self._step)
        b.pose[:2] -= across * left  # the view is across where the distance is least
        self._step = max(MIN_STEP, 0.5 * self._step)
        self._restart()
        return self._arrival(se2_relative(b.pose, target))

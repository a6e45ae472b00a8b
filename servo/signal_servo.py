"""``SignalServo``: servo between manifolds by F^j(k) (Section II-G), camera and odometry only.

1. *Observe and localise.* Turn in place once around; at every few degrees compare the image
   with the stored views (:class:`~servo.localise.ImageLocaliser`: the clusters eq. 13 ranks
   first, then the best horizontally-aligned view). The best match over the turn is the global
   fix: a stored view and the odometry heading that faces the way it looks.
2. *Route.* The shortest path over the view graph (:class:`~servo.route.RouteGraph`) from that
   view to the target, cut into waypoint views about ``spacing`` apart.
3. *Servo.* Toward the current waypoint: heading from image alignment (the best horizontal
   shift against the waypoint image; odometry carries the heading across the turns between
   waypoints, where the images share nothing), forward or in reverse as the recording is
   driven (:func:`steer`). :class:`WaypointTracker` moves on when F toward the next waypoint
   overtakes F toward the current one (view-sequence navigation).
4. *Arrive.* On the target, drive while F toward it rises and stop past its peak.

The controller never reads the simulator's truth; ``info`` is ignored.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from common.geometry import se2_compose, se2_relative, wrap_angle
from common.validation import check_int
from servo.localise import ImageLocaliser
from servo.map_types import ServoMap
from servo.route import RouteGraph
from servo.steering import Arrival, pursue
from sim.simulator import CONTROL_DT


@dataclass(frozen=True)
class SignalServoConfig:
    """Everything that tunes :class:`SignalServo` (tuned on the ``dev`` split only).

    speed / reverse_speed : m/s forward and backward (a recording driven backwards).
    spacing : m between waypoint views.
    turn_rate : rad/s of the observing turn and of turns toward an odometry heading.
    observe_every : steps between localisations during the observing turn.
    heading_gain : omega per rad of heading error.
    image_trust : largest aligned image distance (0..4) at which the image's heading is used.
    odometry_turn : rad of heading error beyond which the robot turns on the spot.
    overrun : a waypoint is given up after driving ``overrun`` times its distance plus 0.5 m.
    arrive_drop : stop once F toward the target falls below this share of its peak.
    arrive_min : F toward the target (0..1) the peak must reach first.
    reach : m from a waypoint (by odometry) that counts as reaching it when its recording is
        driven backwards (its images face away).
    stuck_steps / backup_steps : commanded motion for ``stuck_steps`` steps that odometry
        does not see means a wall: drive the other way for ``backup_steps`` steps.
    """

    speed: float = 0.8
    reverse_speed: float = 0.45
    spacing: float = 0.8
    turn_rate: float = 1.2
    observe_every: int = 2
    heading_gain: float = 2.0
    image_trust: float = 0.6
    odometry_turn: float = 0.3
    overrun: float = 2.0
    arrive_drop: float = 0.6
    arrive_min: float = 0.05
    stuck_steps: int = 10
    reach: float = 0.4
    backup_steps: int = 8

    def __post_init__(self):
        for name in ("speed", "reverse_speed", "spacing", "turn_rate", "heading_gain",
                     "image_trust", "odometry_turn", "overrun"):  # fmt: skip
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not 0 < self.speed <= 1.5 or not 0 < self.reverse_speed <= 0.5:
            raise ValueError("speed must be in (0, 1.5] and reverse_speed in (0, 0.5] m/s")
        check_int(self.observe_every, "observe_every")
        if not 0 < self.arrive_drop < 1:
            raise ValueError(f"arrive_drop must be in (0, 1), got {self.arrive_drop}")


def steer(heading_error: float, direction: int, config: SignalServoConfig) -> np.ndarray:
    """(v, omega) toward a waypoint whose heading is ``heading_error`` rad to the left:
    turn on the spot when far off, else drive (``direction`` +1 forward, -1 reverse) and
    slow down as the error grows."""
    omega = float(np.clip(config.heading_gain * heading_error, -1.2, 1.2))
    if abs(heading_error) > config.odometry_turn:
        return np.array([0.0, omega])
    v = config.speed if direction > 0 else -config.reverse_speed
    return np.array([v * (1.0 - 0.7 * abs(heading_error) / config.odometry_turn), omega])


class WaypointTracker:
    """Which waypoint view the robot is servoing to: the current one until F toward the next
    overtakes it (or, where both are 0, the next one aligns better), or until the robot has
    driven well past the distance the map puts between them."""

    def __init__(self, waypoints: list[int], directions: np.ndarray, gaps: np.ndarray,
                 overrun: float):  # fmt: skip
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

    def update(self, f_current: float, f_next: float, d_current: float, d_next: float,
               moved: float) -> bool:  # fmt: skip
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


class SignalServo:
    """Servo to a stored view by F^j(k) with the camera and odometry (see the module doc).

    Parameters
    ----------
    servo_map : ServoMap
    config : SignalServoConfig, optional
    world : str, optional   the world it will drive in (a map of another world is refused).

    Attributes (after ``act``)
    ----------
    phase_ : "observe", "follow", "arrive" or "done".
    route_ : stored views of the route; ``waypoint_``: the current waypoint view.
    manifold_ : cluster of the current image by eq. 13 (``predict``).
    done_ : bool
    """

    def __init__(self, servo_map: ServoMap, *, config: SignalServoConfig | None = None,
                 world: str | None = None):  # fmt: skip
        if not isinstance(servo_map, ServoMap):
            raise TypeError(f"servo_map must be a ServoMap, got {type(servo_map).__name__}")
        if world is not None:
            servo_map.check_world(world)
        self.map = servo_map
        self.config = config or SignalServoConfig()
        if not isinstance(self.config, SignalServoConfig):
            raise TypeError("config must be a SignalServoConfig")
        self.localiser = ImageLocaliser(servo_map)
        self.routes = RouteGraph(servo_map)
        self.target = None

    def reset(self, target: int, info: dict | None = None) -> None:
        """Start an episode toward stored view ``target`` (``info`` is ignored)."""
        self.target = self.map.check_view(target, "target")
        self.phase_ = "observe"
        self.done_ = False
        self.route_: list[int] = []
        self.waypoint_: int | None = None
        self.manifold_ = -1
        self._odo = None
        self._turned = 0.0
        self._steps = 0
        self._best = (np.inf, None, 0.0)  # aligned distance, view, odometry heading facing it
        self._f_peak = 0.0
        self._moves: deque = deque(maxlen=self.config.stuck_steps)
        self._backup = 0
        self._last_direction = 1

    def _check(self, observation) -> tuple[np.ndarray, np.ndarray]:
        if not isinstance(observation, dict):
            raise ValueError(f"observation must be a dict, got {type(observation).__name__}")
        for key in ("image", "odometry"):
            if key not in observation:
                raise ValueError(f"observation is missing {key!r}")
        x = self.localiser.features(observation["image"])
        odo = np.asarray(observation["odometry"], np.float64)
        if odo.shape != (3,) or not np.all(np.isfinite(odo)):
            raise ValueError(
                f"observation['odometry'] must be a finite (x, y, yaw), got shape {odo.shape}"
            )
        return x, odo

    def act(self, observation, info: dict | None = None) -> np.ndarray:
        """The command (v, omega) for this observation (``info`` is ignored)."""
        if self.target is None:
            raise RuntimeError("call reset(target) before act(observation)")
        x, odo = self._check(observation)
        moved = 0.0 if self._odo is None else float(np.hypot(*(odo[:2] - self._odo[:2])))
        self._prev_odo = odo if self._odo is None else self._odo
        if self._odo is not None:
            self._turned += abs(wrap_angle(odo[2] - self._odo[2]))
        self._odo = odo
        self._steps += 1
        if self.phase_ == "observe":
            return self._observe(x, odo).astype(np.float32)
        if self.phase_ == "done":
            return np.zeros(2, np.float32)
        if self._backup > 0:
            self._backup -= 1
            return np.array([-0.4 * self._last_direction, 0.0], np.float32)
        action = self._follow(x, odo, se2_relative(self._prev_odo, odo))
        self._moves.append((abs(action[0]), moved))
        if len(self._moves) == self._moves.maxlen:
            cmd, got = np.array(self._moves).sum(axis=0)
            if cmd > 0.2 * len(self._moves) and got < 0.2 * cmd * CONTROL_DT:
                self._moves.clear()
                self._last_direction = int(np.sign(action[0]))
                self._backup = self.config.backup_steps
        return action.astype(np.float32)

    # -- phases -----------------------------------------------------------------------------
    def _observe(self, x: np.ndarray, odo: np.ndarray) -> np.ndarray:
        c = self.config
        if self._steps % c.observe_every == 1 or c.observe_every == 1:
            view, yaw, d = self.localiser.localise(x)
            if d < self._best[0]:
                self._best = (d, view, float(odo[2] + yaw))
        if self._turned < 2 * np.pi - c.turn_rate * CONTROL_DT:
            return np.array([0.0, c.turn_rate])
        _, view, heading = self._best
        self.manifold_ = int(self.map.clusters[view])
        self.route_ = self.routes.route(view, self.target)
        self._frames = self.routes.frames(self.route_)
        waypoints, directions = self.routes.waypoints(self.route_, self.config.spacing)
        self._index = {w: self.route_.index(w) for w in waypoints}
        pos = self._frames[[0, *self._index.values()], :2]
        gaps = np.hypot(*np.diff(pos, axis=0).T)
        self.tracker = WaypointTracker(waypoints, directions, gaps, c.overrun)
        # The robot in the route's frame: at the fix's view, turned from its heading by what
        # odometry measured since; odometry carries it, waypoint images reset it.
        self._pose = np.array([0.0, 0.0, wrap_angle(odo[2] - heading)])
        self._arrival = Arrival()
        self.waypoint_ = waypoints[0]
        self.phase_ = "follow"
        return np.zeros(2)

    def _follow(self, x: np.ndarray, odo: np.ndarray, odo_step: np.ndarray) -> np.ndarray:
        c, t = self.config, self.tracker
        self._pose = se2_compose(self._pose, odo_step)
        frame = self._frames[self._index[t.current]]
        goal = se2_relative(self._pose, frame)  # the waypoint view's pose in the robot frame
        if t.directions[t.index] < 0:
            # The recording is driven backwards: its images face away from the way to go and
            # tell nothing ahead, so drive facing the way by odometry from the last image fix.
            if t.last:
                action = self._arrival(goal)
                if self._arrival.done:
                    self.phase_, self.done_ = "done", True
                return action
            if np.hypot(*goal[:2]) < c.reach:
                t.advance()
                self.waypoint_ = t.current
            return pursue(goal[:2], c.speed)
        nxt = t.next if t.next is not None else t.current
        d, yaw = self.localiser.align(x, [t.current, nxt])
        seen = d[0] <= c.image_trust and abs(wrap_angle(frame[2] - yaw[0] - self._pose[2])) < 0.5
        if seen:
            # the image fixes the heading relative to the view: robot yaw = view yaw - error
            self._pose[2] = wrap_angle(frame[2] - yaw[0])
            goal = se2_relative(self._pose, frame)
        if abs(goal[2]) > c.odometry_turn:
            return steer(float(goal[2]), 1, c)  # turn to face the view (odometry) first
        error = float(yaw[0]) if seen else float(goal[2])
        f_cur = self.localiser.signal(x, t.current)
        if not t.last:
            f_next = self.localiser.signal(x, nxt)
            if t.update(f_cur, f_next, d[0], d[1], float(np.hypot(*odo_step[:2]))):
                # F has peaked on the waypoint just left: the robot is about there
                self._pose[:2] = frame[:2]
                self.waypoint_ = t.current
        else:
            self.phase_ = "arrive"
            self._f_peak = max(self._f_peak, f_cur)
            if self._f_peak >= c.arrive_min and f_cur < c.arrive_drop * self._f_peak:
                self.phase_, self.done_ = "done", True
                return np.zeros(2)
        return steer(error, 1, c)

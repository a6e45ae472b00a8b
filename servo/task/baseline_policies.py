"""What ``ManifoldServo`` is compared with: random, greedy F-probing and an oracle.

The three are a random policy, the paper's literal greedy F-probing, and an oracle that knows
the true pose (the upper bound).

Every policy has ``reset(target, info)`` and ``act(observation, info) -> (v, omega)``; only the
oracle reads ``info`` (the simulator's truth).
"""

from __future__ import annotations

import numpy as np

from common.blas import single_threaded_blas
from common.geometry import se2_relative
from common.validation import check_finite, check_int
from scenes import World
from servo.geodesic import GeodesicField
from servo.localise import ImageLocaliser, check_observation
from servo.maps import ServoMap
from servo.route import RouteGraph
from servo.steering import Arrival, pursue
from servo.waypoint_tracker import WaypointTracker
from sim.simulator import OMEGA_LIMIT, V_LIMITS


def _positive(value, name: str) -> float:
    """Check that ``value`` is a finite number > 0 (m/s or m).

    NaN or a negative would steer nowhere, silently.
    """
    value = check_finite(value, name)
    if value <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return value


class RandomPolicy:
    """Uniform random commands, each held for ``hold`` steps: the benchmark's lower bound.

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws the commands, uniform over the action space.
    hold : int, default 5
        Steps each command is held.

    Attributes
    ----------
    rng, hold
        The parameters.

    Examples
    --------
    >>> import numpy as np
    >>> from servo.task import RandomPolicy
    >>> policy = RandomPolicy(np.random.default_rng(0), hold=2)
    >>> policy.reset(target=0)
    >>> a, b, c = (policy.act(None) for _ in range(3))
    >>> bool((a == b).all()), bool((b == c).all()), a.dtype
    (True, False, dtype('float32'))

    See Also
    --------
    servo.task.GreedyFProbing : Greedy ascent on F by probing.
    servo.task.OraclePolicy : The upper bound, on the true pose.
    """

    def __init__(self, rng: np.random.Generator, hold: int = 5):
        if not isinstance(rng, np.random.Generator):
            raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        # hold=0 would draw one command and never another (the count goes negative)
        self.rng, self.hold = rng, check_int(hold, "hold")
        self._left, self._action = 0, np.zeros(2)

    def reset(self, target: int, info: dict | None = None) -> None:
        """Start a new episode: the next step draws a new command.

        Parameters
        ----------
        target : int
            The target view (not read).
        info : dict, optional
            The env's info (not read).
        """
        self._left = 0

    def act(self, observation, info: dict | None = None) -> np.ndarray:
        """Return the current random command, drawn anew every ``hold`` steps.

        Parameters
        ----------
        observation : dict
            The env's observation (not read).
        info : dict, optional
            The env's info (not read).

        Returns
        -------
        ndarray of shape (2,), float32
            The command (v m/s, omega rad/s).
        """
        if self._left == 0:
            self._action = self.rng.uniform((V_LIMITS[0], -OMEGA_LIMIT), (V_LIMITS[1], OMEGA_LIMIT))
            self._left = self.hold
        self._left -= 1
        return self._action.astype(np.float32)


# Small motions a probe can undo exactly by the opposite command: (v, omega) for one step.
PROBES = np.array([(0.5, 0.0), (0.4, 0.8), (0.4, -0.8), (0.0, 1.0), (0.0, -1.0), (-0.5, 0.0)])


class GreedyFProbing:
    """The paper's greedy servo, literally: probe motions, keep the one raising F^j(k) most.

    F^j(k) is eq. 13 toward a stored view; the probing repeats until the episode ends.

    Each probe is executed for one step, F is read from the next image, and the probe is
    undone by the opposite command; after all probes the best is executed ``commit`` times.

    With ``waypoints`` (the fair baseline, ``policy="greedy"``), F is taken toward the next
    waypoint view of a route in the current manifold: the first image is localised
    (`ImageLocaliser`), the route over the view graph is cut into
    waypoints ``spacing`` apart, and the probing moves on when F toward the next waypoint
    overtakes F toward the current one (`WaypointTracker`).
    Without (``policy="greedy-target"``), F is taken toward the final target only, whose cluster
    gives no signal from another manifold.

    Parameters
    ----------
    servo_map : ServoMap
        The map whose clustering gives F.
    commit : int, default 8
        Steps the best probe is executed for.
    waypoints : bool, default True
        Ascend F toward waypoint views along a route rather than toward the target only.
    spacing : float, default 0.8
        Distance between waypoint views, m.

    Attributes
    ----------
    map : ServoMap
        The map.
    commit, waypoints, spacing
        The parameters.
    budget_factor : int
        The evaluation multiplies its step limit by this, so that the probing (12 probe steps
        per ``commit`` steps of motion) can cover the route and the result measures F, not the
        step budget.
    target : int or None
        The target view (None before [`reset`][servo.task.baseline_policies.GreedyFProbing.reset]).
    waypoint_ : int
        The view F is ascended toward.

    Examples
    --------
    >>> import sim  # headless rendering, chosen before anything imports mujoco
    >>> from servo import load_or_build
    >>> from sim.collect import CollectionSettings, collect_dataset
    >>> data = collect_dataset("lawn-40", CollectionSettings(worlds=("lawn",), frames=40),
    ...                        jobs=1, progress=False)  # three drives of 40 frames, ~10 s
    >>> servo_map = load_or_build("lawn", data, cache="servo-maps", progress=False)
    >>> from servo import ServoEnv
    >>> from servo.task import GreedyFProbing
    >>> env = ServoEnv("lawn", servo_map, max_steps=5)
    >>> obs, info = env.reset(seed=1)
    >>> policy = GreedyFProbing(servo_map)
    >>> policy.reset(info["target_view"])
    >>> policy.budget_factor, policy.act(obs).shape
    (3, (2,))

    See Also
    --------
    servo.camera_only.SignalServo : The camera-only controller, servoing by F along a route.
    mapping.manifold.ManifoldClustering.signal : F^j(k) of eq. 13.
    """

    def __init__(
        self, servo_map: ServoMap, commit: int = 8, *, waypoints: bool = True, spacing: float = 0.8
    ):
        check_int(commit, "commit")
        self.map, self.commit = servo_map, int(commit)
        self.waypoints, self.spacing = bool(waypoints), float(spacing)
        self.budget_factor = 1 + int(np.ceil(2 * len(PROBES) / self.commit))
        self.localiser = ImageLocaliser(servo_map)
        self.routes = RouteGraph(servo_map) if waypoints else None
        self.target = None

    def reset(self, target: int, info: dict | None = None) -> None:
        """Start a new episode toward stored view ``target``.

        Parameters
        ----------
        target : int or Target
            The target's stored-view index.
        info : dict, optional
            The env's info (not read).
        """
        self.target = self.map.check_view(target, "target")
        self.waypoint_ = self.target
        self.tracker = None
        self._plan: list[tuple[str, int]] = []
        self._scores = np.full(len(PROBES), -np.inf)
        self._pending: int | None = None
        self._odo = None

    def _start(self, x: np.ndarray) -> None:
        view, _, _ = self.localiser.localise(x)
        route = self.routes.route(view, self.target)
        waypoints, directions = self.routes.waypoints(route, self.spacing)
        gaps = np.full(len(waypoints), self.spacing)
        self.tracker = WaypointTracker(waypoints, directions, gaps, overrun=np.inf)
        self.waypoint_ = self.tracker.current

    def act(self, observation, info: dict | None = None) -> np.ndarray:
        """Return the command (v, omega): the next probe, its undoing, or the best probe held.

        Parameters
        ----------
        observation : dict
            The env's observation; its ``image`` is read.
        info : dict, optional
            The env's info (not read).

        Returns
        -------
        ndarray of shape (2,), float32
            The command (v m/s, omega rad/s).
        """
        with single_threaded_blas():  # small products: BLAS threads only spin (SignalServo)
            return self._act(observation)

    def _act(self, observation) -> np.ndarray:
        if self.target is None:
            raise RuntimeError("call reset(target) before act(observation)")
        check_observation(observation, ("image",))
        x = self.localiser.features(observation["image"])
        if self.waypoints and self.tracker is None:
            self._start(x)
        if self._pending is not None:  # the image after a probe: score it
            self._scores[self._pending] = self.localiser.signal(x, self.waypoint_)
            self._pending = None
        if not self._plan:
            if self.tracker is not None and not self.tracker.last:
                t = self.tracker
                f = [self.localiser.signal(x, v) for v in (t.current, t.next)]
                if t.update(f[0], f[1], 1.0, 1.0, 0.0):
                    self.waypoint_ = t.current
                    self._scores[:] = -np.inf
            if np.isfinite(self._scores).all():
                best = int(np.argmax(self._scores))
                self._plan = [("go", best)] * self.commit
                self._scores[:] = -np.inf
            else:
                self._plan = [p for k in range(len(PROBES)) for p in (("probe", k), ("undo", k))]
        kind, k = self._plan.pop(0)
        if kind == "probe":
            self._pending = k
            return PROBES[k].astype(np.float32)
        return (-PROBES[k] if kind == "undo" else PROBES[k]).astype(np.float32)


class OraclePolicy:
    """Follows the shortest free-space route to the target using the *true* pose: the upper bound.

    Same steering as the controller (pure pursuit, then the arrival law), so the gap between
    the two is what localisation from images and scans costs. It reads ``info["pose"]`` and
    ``info["target_pose"]``, the env's ground truth.

    Parameters
    ----------
    world : World
        The world, whose free space the route is planned in.
    speed : float, default 1.0
        Cruise speed, m/s.
    lookahead : float, default 1.0
        Distance ahead along the route of the pursued point, m.

    Attributes
    ----------
    world, speed, lookahead
        The parameters.
    field : GeodesicField or None
        The distance field to the target (None before
        [`reset`][servo.task.baseline_policies.OraclePolicy.reset]).

    Examples
    --------
    >>> import sim  # headless rendering, chosen before anything imports mujoco
    >>> from servo import load_or_build
    >>> from sim.collect import CollectionSettings, collect_dataset
    >>> data = collect_dataset("lawn-40", CollectionSettings(worlds=("lawn",), frames=40),
    ...                        jobs=1, progress=False)  # three drives of 40 frames, ~10 s
    >>> servo_map = load_or_build("lawn", data, cache="servo-maps", progress=False)
    >>> from scenes import build_world
    >>> from servo import ServoEnv
    >>> from servo.task import OraclePolicy
    >>> env = ServoEnv("lawn", servo_map, max_steps=200, odometry_noise=False)
    >>> obs, info = env.reset(seed=1)
    >>> policy = OraclePolicy(build_world("lawn"))
    >>> policy.reset(info["target_view"], info)  # the one policy given the truth
    >>> start = info["distance"]
    >>> for _ in range(20):
    ...     obs, reward, terminated, truncated, info = env.step(policy.act(obs, info))
    >>> bool(info["distance"] < start)
    True

    See Also
    --------
    servo.ManifoldServo : The controller on the same steering, without the truth.
    servo.task.RandomPolicy : The lower bound.
    """

    def __init__(self, world: World, speed: float = 1.0, lookahead: float = 1.0):
        self.world = world
        self.speed = _positive(speed, "speed")
        self.lookahead = _positive(lookahead, "lookahead")
        self.field = None

    def reset(self, target: int, info: dict | None = None) -> None:
        """Start a new episode toward ``info["target_pose"]`` (the env's truth).

        Parameters
        ----------
        target : int
            The target view (not read: the pose is taken from ``info``).
        info : dict
            The env's info, holding ``target_pose``.
        """
        if info is None or "target_pose" not in info:
            raise ValueError("OraclePolicy.reset needs the env's info (target_pose)")
        self.target_pose = np.asarray(info["target_pose"], np.float64)
        self.field = GeodesicField(self.world, self.target_pose)
        self._arrival = Arrival()

    def act(self, observation, info: dict | None = None) -> np.ndarray:
        """Return the command (v, omega) along the shortest path from ``info["pose"]``.

        The pose is the env's truth.

        Parameters
        ----------
        observation : dict
            The env's observation (not read).
        info : dict
            The env's info, holding the true ``pose``.

        Returns
        -------
        ndarray of shape (2,), float32
            The command (v m/s, omega rad/s).
        """
        if self.field is None:
            raise RuntimeError("call reset(target, info) before act(observation, info)")
        if info is None or "pose" not in info:
            raise ValueError("OraclePolicy.act needs the env's info (pose)")
        pose = np.asarray(info["pose"], np.float64)
        goal = se2_relative(pose, self.target_pose)
        if self.field.distance(pose[:2]) < self.lookahead:
            return self._arrival(goal).astype(np.float32)
        n = int(np.ceil(self.lookahead / self.field.grid.resolution)) + 1
        ahead = self.field.path(pose[:2], max_points=n)[-1]
        point = se2_relative(pose, np.r_[ahead, 0.0])
        return pursue(point[:2], self.speed).astype(np.float32)

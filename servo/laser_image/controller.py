"""``ManifoldServo``: the laser + image controller, from anywhere to a stored view (II-G).

What the robot has: its camera image, its laser scan and its odometry (never the true pose).
The map is the servo map's views placed in one frame by sensing only
(`MetricMap`). An episode runs in phases:

1. *Observe.* Turn once around on the spot: the scans, joined by odometry, make an all-round
   scan, and an image is kept every few steps. The heading is unknown at the start, and a
   forward-looking 180-degree laser sees too little of a corridor to place itself.
2. *Localise.* `GlobalLocaliser`: the all-round scan on the
   point map at every free place and heading, the best refined by ICP, look-alikes told apart
   by the images against the stored views there. The clustering's ``predict`` (eq. 13) names
   the current manifold.
3. *Drive.* The shortest path through the map's sensed free space to the target view
   (`GeodesicField`), pure pursuit ``lookahead`` ahead along it; the
   pose carried by odometry and corrected each step by ICP on the point map
   (`ScanTracker`). ``route_`` / ``manifold_route_``: the
   stored views along the path and the clusters they cross (the manifold graph's path).
4. *Arrive.* On the last metre, drive the target view's pose in the robot frame to zero
   (`Arrival`), then verify: the scan must match the target view's.
   Driving the view error to zero is what makes F^j(k) toward the target (eq. 13) peak; the
   literal ascent on F is ``GreedyFProbing``, and the camera-only ascent is ``SignalServo``.
5. *Recover.* The scan no longer fits the map for ``lost_steps`` steps, or the arrival check
   fails: observe and localise again (up to ``max_relocalisations`` times). Commanded motion
   that odometry does not see: back up.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from scipy.spatial import cKDTree

from common.deprecation import moved_names
from common.geometry import scan_to_points, se2_compose, se2_relative, transform_points
from servo.geodesic import GeodesicField
from servo.laser_image.config import ManifoldServoConfig
from servo.laser_image.laser_localise import GlobalLocaliser, ScanTracker
from servo.laser_image.metric_map import MetricMap
from servo.laser_image.view_match import ViewMatcher
from servo.localise import ImageLocaliser, check_image, check_observation, check_odometry
from servo.maps import ServoMap
from servo.steering import Arrival, pursue
from sim.simulator import CONTROL_DT

# the settings' old name here, kept for one release with a DeprecationWarning
__getattr__ = moved_names(__name__, {"ServoConfig": "servo.laser_image:ManifoldServoConfig"})[0]

SCAN_POINTS = 90  # current-scan points used by tracking ICP (every k-th return)


class ManifoldServo:
    """Servo to a stored view of a [`ServoMap`][servo.maps.types.ServoMap] with laser and camera.

    An episode runs in phases (see the module's description): observe (turn once round on the
    spot), localise globally (the all-round scan on the map's point map, look-alikes told apart
    by the images), drive the shortest path to the target view while tracking by ICP, arrive and
    verify by the scan, and recover by localising again when the scan stops fitting. The
    controller reads the observation only (image, scan, odometry relative to the episode's
    start), never the simulator's truth.

    Parameters
    ----------
    servo_map : ServoMap
        The map of the world it drives in.
    config : ManifoldServoConfig, optional
        Its settings; default ``ManifoldServoConfig()``.
    world : str, optional
        The world it will drive in; a map of another world raises ``MapError``.

    Attributes
    ----------
    map : ServoMap
        The map.
    config : ManifoldServoConfig
        The settings.
    target : int or None
        The target view of the episode (None before
        [`reset`][servo.laser_image.controller.ManifoldServo.reset]).
    phase_ : {"observe", "drive", "done"}
        The phase after the last [`act`][servo.laser_image.controller.ManifoldServo.act].
    pose_ : ndarray of shape (3,) or None
        The robot's pose in the map frame while driving.
    route_ : list of int
        Stored views along the planned path.
    waypoint_ : int or None
        The view of ``route_`` nearest the pursued point.
    manifold_route_ : list of int
        The clusters the path crosses.
    manifold_ : int
        Cluster of the image by eq. 13 (``predict``) at the last localisation; -1 before.
    done_ : bool
        Whether the controller has arrived and stopped.
    relocalisations_ : int
        Global localisations in this episode.

    Examples
    --------
    >>> import sim  # headless rendering, chosen before anything imports mujoco
    >>> from servo import load_or_build
    >>> from sim.collect import CollectionSettings, collect_dataset
    >>> data = collect_dataset("lawn-40", CollectionSettings(worlds=("lawn",), frames=40),
    ...                        jobs=1, progress=False)  # three drives of 40 frames, ~10 s
    >>> servo_map = load_or_build("lawn", data, cache="servo-maps", progress=False)
    >>> import numpy as np
    >>> from servo import ManifoldServo, ServoEnv
    >>> env = ServoEnv("lawn", servo_map, max_steps=20)
    >>> obs, info = env.reset(seed=1)
    >>> policy = ManifoldServo(servo_map, world="lawn")
    >>> policy.reset(info["target_view"])
    >>> action = policy.act(obs)
    >>> policy.phase_, bool(np.allclose(action, [0.0, policy.config.turn_rate]))
    ('observe', True)
    >>> obs, reward, terminated, truncated, info = env.step(action)

    See Also
    --------
    servo.laser_image.ManifoldServoConfig : Its settings.
    servo.camera_only.SignalServo : The camera-only controller.
    servo.ServoEnv : The task it is evaluated on.
    servo.evaluate : The closed-loop evaluation of either controller.
    """

    def __init__(
        self,
        servo_map: ServoMap,
        *,
        config: ManifoldServoConfig | None = None,
        world: str | None = None,
    ):
        if not isinstance(servo_map, ServoMap):
            raise TypeError(f"servo_map must be a ServoMap, got {type(servo_map).__name__}")
        if world is not None:
            servo_map.check_world(world)
        self.config = config or ManifoldServoConfig()
        if not isinstance(self.config, ManifoldServoConfig):
            raise TypeError(
                f"config must be a ManifoldServoConfig, got {type(self.config).__name__}"
            )
        self.map = servo_map
        self.metric = MetricMap(servo_map)
        self.images = ImageLocaliser(servo_map)
        self.localiser = GlobalLocaliser(self.metric, self.images, self.config.image_weight)
        self.tracker = ScanTracker(self.metric)
        self._matcher = ViewMatcher(servo_map)
        self._view_tree = cKDTree(self.metric.poses[:, :2])
        self._fields: dict[int, GeodesicField] = {}
        self.target = None

    # -- API --------------------------------------------------------------------------------
    def reset(self, target: int, info: dict | None = None) -> None:
        """Start a new episode toward stored view ``target``.

        Parameters
        ----------
        target : int
            Index of the target's stored view in the map.
        info : dict or None, default None
            Ignored: the controller never reads the simulator's truth.

        Raises
        ------
        MapError
            When ``target`` is no stored view of the map.
        """
        self.target = self.map.check_view(target, "target")
        if self.target not in self._fields:
            self._fields[self.target] = GeodesicField(
                self.metric.grid, self.metric.poses[target], keep_off=self.config.keep_off
            )
        self._field = self._fields[self.target]
        self.done_ = False
        self.relocalisations_ = 0
        self.manifold_ = -1
        self.route_: list[int] = []
        self.manifold_route_: list[int] = []
        self.waypoint_: int | None = None
        self.pose_ = None
        self._odometry = None
        self._moves: deque = deque(maxlen=self.config.stuck_steps)
        self._backup = 0
        self._observe()

    def act(self, observation, info: dict | None = None) -> np.ndarray:
        """Return the command for this observation.

        Parameters
        ----------
        observation : dict
            The env's observation: ``"image"``, ``"scan"`` (ranges, m; +inf: no return),
            ``"odometry"`` (x, y, yaw from the episode's start) and optionally ``"scan_valid"``.
        info : dict or None, default None
            Ignored: the controller never reads the simulator's truth.

        Returns
        -------
        ndarray of shape (2,), float32
            The command (v, omega): forward speed, m/s, and turn rate, rad/s.

        Raises
        ------
        RuntimeError
            When called before [`reset`][servo.laser_image.controller.ManifoldServo.reset].
        ValueError
            When the observation is malformed.
        """
        if self.target is None:
            raise RuntimeError("call reset(target) before act(observation)")
        image, scan, odo = self._check(observation)
        points = scan_to_points(scan, self.map.angles, self.map.max_range)
        points = points[:: max(1, len(points) // SCAN_POINTS)]
        previous, self._odometry = self._odometry, odo.copy()
        moved = 0.0 if previous is None else float(np.hypot(*(odo[:2] - previous[:2])))
        if self.phase_ == "observe":
            if self._turn(image, points, odo):
                return np.array([0.0, self.config.turn_rate], np.float32)
        elif self.phase_ == "drive":
            self._track(points, se2_compose(self.pose_, se2_relative(previous, odo)))
        if self.phase_ == "done":
            return np.zeros(2, np.float32)
        if self.phase_ == "observe":  # lost while tracking: turn and localise again
            return np.array([0.0, self.config.turn_rate], np.float32)
        return self._decide(points, moved).astype(np.float32)

    # -- phases -----------------------------------------------------------------------------
    def _observe(self) -> None:
        self.phase_ = "observe"
        self._turned = 0.0
        self._turn_start = None
        self._scans: list[tuple[np.ndarray, np.ndarray]] = []
        self._views: list[tuple[np.ndarray, np.ndarray]] = []
        self._bad = 0
        self._corrections: deque = deque(maxlen=self.config.drift_window)
        self._arrival = Arrival(self.config.arrive_radius)

    def _turn(self, image: np.ndarray, points: np.ndarray, odo: np.ndarray) -> bool:
        """One step of the observing turn; True while it goes on, else localise."""
        c = self.config
        if self._scans:
            self._turned += abs(float(se2_relative(self._scans[-1][1], odo)[2]))
        self._scans.append((points, odo))
        if (len(self._scans) - 1) % c.image_every == 0:
            self._views.append((self.images.features(image), odo))
        if self._turned < 2 * np.pi:
            return True
        cloud = np.concatenate([transform_points(se2_relative(odo, o), p) for p, o in self._scans])
        views = [(x, float(se2_relative(odo, o)[2])) for x, o in self._views]
        fix = self.localiser.localise(cloud, views)
        self.manifold_ = int(self.map.clustering.predict(views[-1][0][None])[0])
        self.relocalisations_ += 1
        self.pose_ = fix.pose
        self.fix_ = fix
        self._plan()
        self.phase_ = "drive"
        return False

    def _plan(self) -> None:
        """Plan the stored views along the path from here and the clusters they cross."""
        path = self._field.path(self.pose_[:2])
        d, near = self._view_tree.query(path)
        views = near[d < 1.0]
        keep = np.r_[True, views[1:] != views[:-1]] if len(views) else np.zeros(0, bool)
        self.route_ = [int(v) for v in views[keep]] + [self.target]
        c = self.map.clusters[self.route_]
        self.manifold_route_ = [int(v) for v in c[np.r_[True, c[1:] != c[:-1]]]]

    def _track(self, points: np.ndarray, predicted: np.ndarray) -> None:
        c = self.config
        self.pose_, fit, _ = self.tracker.correct(points, predicted)
        self._bad = self._bad + 1 if fit < c.lost_fit else 0
        self._corrections.append(np.hypot(*(self.pose_[:2] - predicted[:2])))
        drift = sum(self._corrections)
        if (self._bad >= c.lost_steps or drift > c.max_drift) and self._may_relocalise():
            self._observe()

    def _may_relocalise(self) -> bool:
        return self.relocalisations_ <= self.config.max_relocalisations

    def _decide(self, points: np.ndarray, moved: float) -> np.ndarray:
        c = self.config
        if self._backup > 0:
            self._backup -= 1
            return np.array([-0.4, 0.0])
        goal_pose = self.metric.poses[self.target]
        remaining = self._field.distance(self.pose_[:2])
        straight = float(np.hypot(*(goal_pose[:2] - self.pose_[:2])))
        if min(remaining, straight + 0.3) < c.arrive_distance:
            goal = se2_relative(self.pose_, goal_pose)
            action = self._arrival(goal)
            self.waypoint_ = self.target
            if self._arrival.done:
                if self._verified(points, goal) or not self._may_relocalise():
                    self.phase_, self.done_ = "done", True
                else:
                    self._observe()
                return np.zeros(2)
        else:
            path = self._field.path(self.pose_[:2], max_points=int(c.lookahead / 0.1) + 1)
            aim = path[-1]
            self.waypoint_ = int(self._view_tree.query(aim)[1])
            action = pursue(se2_relative(self.pose_, np.r_[aim, 0.0])[:2], c.speed)
        self._moves.append((abs(action[0]), moved))
        if len(self._moves) == c.stuck_steps:
            cmd, got = np.array(self._moves).sum(axis=0)
            if cmd > 0.2 * c.stuck_steps and got < 0.2 * cmd * CONTROL_DT:
                self._moves.clear()
                self._backup = c.backup_steps
                return np.array([-0.4, 0.0])
        return action

    def _verified(self, points: np.ndarray, goal: np.ndarray) -> bool:
        """On arrival the current scan must match the target view's closely."""
        score, _ = self._matcher.score(points, self.target, se2_relative(goal, np.zeros(3)))
        return score >= self.config.verify_score

    def _check(self, observation) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        check_observation(observation, ("image", "scan", "odometry"))
        image = check_image(observation["image"], self.map.image_shape)
        scan = np.asarray(observation["scan"], np.float64)
        odo = check_odometry(observation["odometry"])
        if scan.shape != self.map.angles.shape:
            raise ValueError(
                f"observation['scan'] must have shape {self.map.angles.shape}, got {scan.shape}"
            )
        if np.isnan(scan).any():
            raise ValueError("observation['scan'] must not hold NaN (no return is +inf)")
        if (scan < 0).any():  # -inf too: a range is a distance
            raise ValueError(
                f"observation['scan'] must hold ranges >= 0 (m; no return is +inf), got "
                f"{scan.min()}"
            )
        if "scan_valid" in observation:  # the env's default: no return at max range, flagged
            valid = np.asarray(observation["scan_valid"])
            if valid.shape != scan.shape:
                raise ValueError(
                    f"observation['scan_valid'] must have shape {scan.shape}, got {valid.shape}"
                )
            scan = np.where(valid != 0, scan, np.inf)
        return image, scan, odo

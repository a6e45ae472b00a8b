"""``SignalServo``: servo between manifolds by F^j(k) (Section II-G), camera and odometry only.

1. *Observe and localise.* Turn in place once around; every few degrees compare the image
   with the stored views (`localise`: the clusters eq. 13
   ranks first, then the best horizontally-aligned view). The global fix is a stored view and
   the odometry heading that faces the way it looks: with ``contrast_fix`` (default) the view
   whose best match over the turn stands out most against the turn's other headings
   (`contrast_fix`; every sample is aligned with all views;
   one the turn's images cannot pose the robot against gives way to the next candidate they can,
   ``fix_check``), else the best match over the turn.
2. *Route.* The shortest path over the view graph (`RouteGraph`) from that
   view to the target, in the fix view's frame (the graph's sensed transforms chained), cut
   into waypoint views about ``spacing`` apart.
3. *Servo.* Toward the waypoints along the route: the pose in the route frame is carried by
   odometry and fixed by the images (`RouteBelief`,
   `RouteImageFix`): the heading from the best
   horizontal shift against the route views the camera faces, the position along the route
   from which of them matches best; every few steps a metric pose against
   the best of them (`PoseFixes`: keypoints at the
   view's map-time depths) corrects position and heading at once. `WaypointTracker` moves on
   when F toward the next waypoint overtakes F toward the current one (view-sequence navigation),
   which also tells the robot it is past the current one. Where the route drives its
   recording backwards (out of a branch) the robot reverses, the camera facing the way the
   stored views look, and takes the reverse-stable fix
   (`fix_reversing`), on a map with the parallax
   that fix needs (``reverse_parallax``); on others it turns round and drives on odometry.
4. *Arrive.* At the target view: drive to it, and where F toward it has peaked and fallen,
   take the peak as the view's place (the robot went past it) and come back.
5. *Recover.* Commanded motion that odometry does not see is a wall: back off (reversing,
   also move the belief across toward the side the robot was backing to). Facing route
   views that no image matches for long (following or arriving), or pushing a wall again
   and again while following, means the fix or the belief is wrong: observe and localise
   again.

The controller never reads the simulator's truth; ``info`` is ignored.
"""

from __future__ import annotations

import numpy as np

from common.blas import single_threaded_blas
from common.geometry import se2_relative, wrap_angle
from servo.camera_only.config import SignalServoConfig
from servo.camera_only.metric_pose_fixes import PoseFixes
from servo.camera_only.peak_arrival import PeakArrival
from servo.camera_only.rear_view_heading import LookBack
from servo.camera_only.route_belief import RouteBelief
from servo.camera_only.route_image_fix import RouteImageFix
from servo.camera_only.turn_global_fix import TurnSamples
from servo.camera_only.view_pose import ViewPose
from servo.localise import ImageLocaliser, check_observation, check_odometry
from servo.maps import ServoMap
from servo.route import RouteGraph, RoutePath
from servo.steering import StallWindow, pursue_route
from servo.waypoint_tracker import WaypointTracker
from sim.simulator import CONTROL_DT

__all__ = ["SignalServo", "SignalServoConfig", "WaypointTracker"]

MIN_PARALLAX = 0.02  # rad/m: a floor (the reversing fix's cross gain grows as 1 / parallax)


class SignalServo:
    """Servo to a stored view by F^j(k) (eq. 13) with the camera and odometry only.

    The robot turns on the spot and fixes its place globally from the images, plans a route of
    waypoint views through the map's view graph and follows it, its belief on the route
    corrected by image and metric pose fixes, and arrives at the target where F toward the
    target view peaks. See the package's description for each part.

    Parameters
    ----------
    servo_map : ServoMap
        The map of the world it drives in.
    config : SignalServoConfig, optional
        Its settings; default ``SignalServoConfig()``.
    world : str, optional
        The world it will drive in; a map of another world raises ``MapError``.

    Attributes
    ----------
    map : ServoMap
        The map.
    config : SignalServoConfig
        The settings.
    parallax : float
        The map's image shift per metre across a view's sight (rad/m), from its linked views.
    reverses : bool
        Whether it drives the routes' backward segments in reverse (``config.reverse`` and a map
        whose parallax reaches ``config.reverse_parallax``).
    far_scene : bool
        Whether the map's parallax is below ``config.reverse_parallax`` (grass, sky, trees).
    target : int or None
        The target view of the episode (None before
        [`reset`][servo.camera_only.controller.SignalServo.reset]).
    phase_ : {"observe", "follow", "arrive", "done"}
        The phase after the last [`act`][servo.camera_only.controller.SignalServo.act].
    route_ : list of int
        Stored views of the route.
    waypoint_ : int or None
        The current waypoint view (None while observing).
    manifold_ : int
        Cluster of the current image by eq. 13 (``predict``) at the global fix.
    belief_ : RouteBelief or None
        The pose on the route (`RouteBelief`); None
        while observing.
    done_ : bool
        Whether the controller has arrived and stopped.

    Examples
    --------
    >>> import sim  # headless rendering, chosen before anything imports mujoco
    >>> from servo import load_or_build
    >>> from sim.collect import CollectionSettings, collect_dataset
    >>> data = collect_dataset("lawn-40", CollectionSettings(worlds=("lawn",), frames=40),
    ...                        jobs=1, progress=False)  # three drives of 40 frames, ~10 s
    >>> servo_map = load_or_build("lawn", data, cache="servo-maps", progress=False)
    >>> import numpy as np
    >>> from servo import ServoEnv, SignalServo
    >>> env = ServoEnv("lawn", servo_map, max_steps=20)
    >>> obs, info = env.reset(seed=1)
    >>> policy = SignalServo(servo_map, world="lawn")
    >>> policy.reset(info["target_view"])
    >>> action = policy.act(obs)
    >>> policy.phase_, bool(np.allclose(action, [0.0, policy.config.turn_rate]))
    ('observe', True)

    See Also
    --------
    servo.camera_only.SignalServoConfig : Its settings.
    servo.laser_image.ManifoldServo : The laser + image controller.
    mapping.manifold.ManifoldClustering.signal : F^j(k) of eq. 13.
    servo.ServoEnv : The task it is evaluated on.
    """

    def __init__(
        self,
        servo_map: ServoMap,
        *,
        config: SignalServoConfig | None = None,
        world: str | None = None,
    ):
        if not isinstance(servo_map, ServoMap):
            raise TypeError(f"servo_map must be a ServoMap, got {type(servo_map).__name__}")
        if world is not None:
            servo_map.check_world(world)
        self.map = servo_map
        self.config = SignalServoConfig() if config is None else config
        if not isinstance(self.config, SignalServoConfig):
            raise TypeError(f"config must be a SignalServoConfig, got {type(config).__name__}")
        self.localiser = ImageLocaliser(servo_map)
        self.routes = RouteGraph(servo_map)
        # the image shift per m across a view's sight, from the map's linked views: the
        # reversing fix's model (hallway ~0.15, lawn ~0.05: the scene's depth differs)
        self.parallax = max(self.localiser.parallax(), MIN_PARALLAX)
        # reversing keeps image fixes only where the map's parallax makes them stable
        self.reverses = self.config.reverse and self.parallax >= self.config.reverse_parallax
        # a far scene (grass, sky, trees: little parallax) where bland images match at any
        # shift, so image fixes need a sharp alignment (``fix_contrast``)
        self.far_scene = self.parallax < self.config.reverse_parallax
        # the near ground's extra shift per m across (two bands): measures the offset across
        # the route apart from the heading, where the map says it is resolved
        k = self.localiser.cross_parallax()
        self.cross_parallax = k if k >= self.config.cross_min_parallax else 0.0
        # metric poses against route views from keypoints at the views' map-time depths
        # measure the offset across apart from the heading, in both worlds
        self.poses = PoseFixes(ViewPose(servo_map), self.config) if self.config.pose_every else None
        self.fixes = RouteImageFix(
            self.localiser,
            self.config,
            self.poses,
            far_scene=self.far_scene,
            parallax=self.parallax,
            cross_parallax=self.cross_parallax,
        )
        self.target = None

    def reset(self, target: int, info: dict | None = None) -> None:
        """Start an episode toward stored view ``target``.

        Parameters
        ----------
        target : int
            The stored view to servo to; not a view of the map raises ``MapError``.
        info : dict, optional
            Ignored (the controller never reads the simulator's truth).
        """
        self.target = self.map.check_view(target, "target")
        self.done_ = False
        self.route_: list[int] = []
        self.manifold_ = -1
        self.relocalised_ = 0
        self.bumps_ = 0
        self._odo = None
        self._steps = 0
        self._stall = StallWindow(self.config.stuck_steps)
        self._backup = 0
        self._reversing = False
        self._careful = 0  # steps left of turning on the spot before driving (after a bump)
        self._last_direction = 1
        self._observe_start()

    def _observe_start(self) -> None:
        self.phase_ = "observe"
        self.waypoint_: int | None = None
        self.belief_: RouteBelief | None = None
        self._turned = 0.0
        self._travel = 0.0  # m driven since the last look back (``look_back``)
        self._look: LookBack | None = None
        self._turn = TurnSamples(self.localiser, self.config, self.poses)  # the turn's samples

    def _check(self, observation) -> tuple[np.ndarray, np.ndarray]:
        check_observation(observation, ("image", "odometry"))
        odo = check_odometry(observation["odometry"])
        return self.localiser.features(observation["image"]), odo

    def act(self, observation, info: dict | None = None) -> np.ndarray:
        """Return the command for this observation.

        Parameters
        ----------
        observation : dict
            The camera ``image`` (H, W, 3) and the ``odometry`` pose (x, y, yaw).
        info : dict, optional
            Ignored (the controller never reads the simulator's truth).

        Returns
        -------
        numpy.ndarray
            The command (v, omega), float32.
        """
        # One BLAS thread: the products here are small (an image against a few views, one
        # projection per cluster) and on a busy machine spinning BLAS threads made a step
        # 15x slower (sq. distances to a cluster: 0.4 ms -> 16 ms).
        with single_threaded_blas():
            return self._act(observation)

    def _act(self, observation) -> np.ndarray:
        if self.target is None:
            raise RuntimeError("call reset(target) before act(observation)")
        x, odo = self._check(observation)
        self._image = observation["image"]
        prev = odo if self._odo is None else self._odo
        step = se2_relative(prev, odo)
        self._turned += abs(float(step[2]))
        self._travel += float(np.hypot(step[0], step[1]))
        self._odo = odo
        self._steps += 1
        if self.belief_ is not None:
            self.belief_.predict(step)
        if self.phase_ == "observe":
            return self._observe(x, odo).astype(np.float32)
        if self._backup > 0:
            self._backup -= 1
            return np.array([-0.4 * self._last_direction, 0.0], np.float32)
        action = self._follow(x, step)
        self._reversing = bool(action[0] < 0)
        if self._stall.stalled(action[0], odo):
            self._last_direction = int(np.sign(action[0])) or 1
            self._bumped(self._last_direction)
        return action.astype(np.float32)

    def _bumped(self, direction: int) -> None:
        """Commanded motion odometry did not see: a wall. Back off the way it came.

        Reversing, the belief also moves ``bump_shift`` across the route toward the side the
        robot was backing to (`bumped`): out of a
        branch the reversing fix leaves the belief ~0.7 m off, and without it every back-off
        and retry drives the same line into the same wall (dev traces: 10-12 bumps at one
        place). Forward, the image fix's funnel corrects the offset, and shifting did not
        help on dev.
        """
        self._stall.clear()
        self._backup = self.config.backup_steps
        self._careful = 3 * self.config.backup_steps
        self.bumps_ += 1
        if direction < 0 and self.config.bump_shift > 0 and self.belief_ is not None:
            self.belief_.bumped(direction, self.config.bump_shift)

    # -- phases -----------------------------------------------------------------------------
    def _observe(self, x: np.ndarray, odo: np.ndarray) -> np.ndarray:
        c = self.config
        if self._steps % c.observe_every == 0 or c.observe_every == 1:
            self._turn.observe(x, self._image, odo)
        if self._turned < 2 * np.pi - c.turn_rate * CONTROL_DT or not self._turn.samples:
            return np.array([0.0, c.turn_rate])
        self._plan(odo)
        return np.zeros(2)

    def _plan(self, odo: np.ndarray) -> None:
        """Route from the global fix's view to the target and start following it."""
        c = self.config
        view, heading = self._turn.fix()
        self.manifold_ = int(self.map.clusters[view])
        self.route_ = self.routes.route(view, self.target)
        path = RoutePath(self.routes.frames(self.route_))
        waypoints, directions = self.routes.waypoints(self.route_, c.spacing)
        self._wp_index = np.array([self.route_.index(w) for w in waypoints])
        gaps = np.diff(np.r_[0.0, path.arc[self._wp_index]])
        self.tracker = WaypointTracker(waypoints, directions, gaps, np.inf)
        # The robot in the route's frame: at the fix's view, turned from its heading by what
        # odometry measured since (or where the turn's images pose it against the view);
        # odometry carries it, images correct it.
        start = None
        if self.poses is not None:
            start = self.poses.start(view, self._turn.distances(view), path, odo)
        if start is None:
            start = [0.0, 0.0, wrap_angle(odo[2] - heading)]
        self.belief_ = RouteBelief(path, start, c.window)
        self._arrival = PeakArrival(c)
        self._lost = 0
        self._plan_bumps = self.bumps_
        self.waypoint_ = waypoints[0]
        self.phase_ = "follow"

    def _image_fix(self, x: np.ndarray) -> None:
        """Correct the belief by the image.

        Also count the steps no route view matched (`fix`).
        """
        fixed = self.fixes.fix(
            self.belief_,
            self.route_,
            x,
            self._image,
            self._odo,
            self._steps,
            reversing=self._reversing,
            following=self.phase_ == "follow",
        )
        if fixed is not None:
            self._lost = 0 if fixed else self._lost + 1

    def _advance(self, x: np.ndarray) -> None:
        """Move on to the next waypoint where the robot is past the current one.

        That is when F toward the next overtakes F toward the current one, or when the belief
        has passed the current one.
        """
        t, b = self.tracker, self.belief_
        arc = b.path.arc[self._wp_index]
        while not t.last and b.s >= arc[t.index] - 0.05:
            t.advance()
        if not t.last and t.directions[t.index] > 0:
            f_cur, f_next = self.localiser.signals(x, [t.current, t.next])
            if f_cur > self.config.arrive_min and t.update(f_cur, f_next, 1.0, 1.0, 0.0):
                b.shift_along(max(0.0, arc[t.index - 1] - b.s))
        self.waypoint_ = t.current

    def _follow(self, x: np.ndarray, step: np.ndarray) -> np.ndarray:
        c, b = self.config, self.belief_
        if self._look is not None:
            action = self._look.step(b, CONTROL_DT)
            if self._look.fixing:
                self._image_fix(x)
            if action is not None:
                return action
            self._look, self._travel = None, 0.0
        self._image_fix(x)
        # pushing a wall again and again at one place while following: the belief is off
        # across the route (the arrival's back-and-forth by the target looks like a wall)
        walled = (
            c.relocalise_bumps > 0
            and self.bumps_ - self._plan_bumps >= c.relocalise_bumps
            and self.phase_ == "follow"
        )
        unpeaked = (
            self.phase_ == "arrive"
            and self._arrival.swept_peak is not None
            and self._arrival.swept_peak < c.unpeaked
        )
        if (
            self.phase_ in (("follow", "arrive") if c.relocalise_arrive else ("follow",))
            and (self._lost > c.relocalise_after or walled or unpeaked)
            and self.relocalised_ < c.max_relocalise
        ):
            self.relocalised_ += 1
            self._observe_start()
            return np.zeros(2)
        self._advance(x)
        t = self.tracker
        if (
            c.look_back > 0
            and self.phase_ == "follow"
            and not self.reverses
            and t.directions[t.index] < 0
            and self._travel >= c.look_back
        ):
            # turned round on a recording driven backwards: no view faces this way
            self._look = LookBack(float(b.pose[2]), c.look_steps, c.turn_rate)
            return self._look.step(b, CONTROL_DT)
        if self.phase_ == "follow" and b.path.length - b.s > c.arrive_distance:
            return self._drive(b.goal(b.s + c.lookahead))
        self.phase_ = "arrive" if self.phase_ == "follow" else self.phase_  # latched
        return self._arrive(x)

    def _drive(self, goal: np.ndarray) -> np.ndarray:
        """Pursue ``goal`` (robot frame), forward or in reverse.

        In reverse where the route drives its recording backwards
        (``WaypointTracker.directions`` < 0) on a map that reverses, so the camera keeps facing
        the way the stored views look and image fixes stay available (`pursue_route`).
        """
        c, t = self.config, self.tracker
        reverse = self.reverses and not t.directions[t.index] > 0
        careful = self._careful > 0
        self._careful -= int(careful)
        speed = c.reverse_speed if reverse else c.speed
        return pursue_route(goal, reverse, speed, careful, c.turn_rate)

    def _arrive(self, x: np.ndarray) -> np.ndarray:
        """At the target: the F peak (`PeakArrival`)."""
        b = self.belief_
        action = self._arrival.step(
            b, b.path.frames[-1], lambda: self.localiser.signal(x, self.target)
        )
        self.done_ = self._arrival.done
        self.phase_ = "done" if self.done_ else "arrive"
        return action

"""``ServoEnv``: the servo task of Section II-G as a Gymnasium env."""

from __future__ import annotations

import os

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from common.blas import single_threaded_blas
from common.geometry import se2_relative, wrap_angle
from common.validation import (
    CheckedKeywords,
    check_bool,
    check_finite,
    check_int,
    check_keys,
)
from servo.maps import MapError, ServoMap, load_map, load_or_build
from servo.task.registration import MAX_EPISODE_STEPS, spec_with_own_limit, warn_of_map_object
from sim.env import NO_RETURN, NavigationEnv, check_pose_option, check_world
from sim.odometry import OdometryConfig

SUCCESS_RADIUS = 0.5  # m
SUCCESS_HEADING = np.deg2rad(20.0)
START_RADIUS = 0.4  # m: start within this of a stored view (on the recorded routes)
START_YAW = 0.3  # rad: and within this of its heading (17 deg)
STUCK_WINDOW = 30  # steps in contact without moving STUCK_DISTANCE end the episode
STUCK_DISTANCE = 0.1  # m
SUCCESS_REWARD = 1.0
COLLISION_PENALTY = 0.1


RESET_OPTIONS = ("pose", "start_manifold", "start_view", "target", "target_manifold")


class ServoEnv(CheckedKeywords, gym.Env):
    """Servo the robot to a stored view of the world's map (a Gymnasium env).

    Registered as ``topomap/HallwayServo-v0`` and ``topomap/LawnServo-v0``.

    Description
        The robot starts near a stored view on one manifold (within ``START_RADIUS`` and
        ``START_YAW`` of it, so the task lies on the recorded routes) and must reach the pose
        of a stored view, the target, on another manifold (``cross_manifold``) or any.

    Action Space
        ``Box([-0.5, -1.5], [1.5, 1.5], float32)``: (v m/s, omega rad/s), as ``NavigationEnv``.

    Observation Space
        ``Dict(image, scan, scan_valid, odometry, target_image, target_scan,
        target_scan_valid)``: the camera image (H, W, 3) uint8, the laser ranges (B,) float32
        in ``[0, max_range]`` with their mask (B,) of returns (``MultiBinary``: 0 where the
        beam hit nothing and reads ``max_range``), the odometry pose (3,) float64 *relative to
        the start of the episode* (what wheel encoders give; the env's absolute odometry starts
        at the true pose and would leak it), and the target view's image, scan and mask.
        ``no_return="inf"``: the raw ranges, ``+inf`` for no return, and no masks (as
        [`NavigationEnv`][sim.env.NavigationEnv]).

    Rewards
        ``reward_signal``: the change of F^j(k) toward the target (eq. 13) over the step,
        divided by F at the target view itself, times ``signal_weight``;
        ``reward_success`` (``success_reward`` on arrival) and ``reward_collision``
        (``-collision_penalty`` per step in contact).

    Episode End
        Terminated on success (within 0.5 m and 20 deg of the target pose) or when stuck
        (``STUCK_WINDOW`` steps in contact while moving less than ``STUCK_DISTANCE``);
        truncated after ``max_steps``, the env's one time limit (it is registered without a
        ``TimeLimit`` wrapper, so ``gym.make(..., max_steps=n)`` is not cut short by another
        clock; ``spec.max_episode_steps`` is ``max_steps``). ``info["reason"]``: "success",
        "stuck", "time limit" or None while running; "time limit" too when an outer
        ``TimeLimit`` (``gym.make(..., max_episode_steps=n)``) cuts the episode, which the
        registered ids' [`TruncationReason`][servo.task.registration.TruncationReason] wrapper
        reports.

    Info
        ``pose`` (true), ``target_pose``, ``target_view``, ``start_manifold``,
        ``target_manifold``, ``junctions`` (between those two manifolds), ``distance``,
        ``heading_error``, ``success``, ``reason``,
        ``signal`` (F), ``path_length``, the reward parts and the base env's info. Truth is for
        evaluation only.

    Reset options
        ``target`` (stored view index) or ``target_manifold`` (name); ``start_view`` (stored
        view index) or ``start_manifold`` (name), or ``pose`` (x, y, yaw). Any other key is
        an error naming the closest of these.

    Version History
        v0: initial version.

    Parameters
    ----------
    world : str, optional
        The world: ``"hallway"``, ``"lawn"`` or a generated world ``FAMILY:SEED`` of the id's
        family; default the one the env id names, else "hallway" (a world that contradicts
        the id raises ``ValueError``). The map must be of this world and its floor plan.
    servo_map : ServoMap, str, path or None, default None
        The map: a ``ServoMap``, the path of a saved one (cheap to pass to vector-env workers,
        and the form to give ``gym.make``: a map object there warns, since the spec would hold
        its arrays), or None for the world's cached default map
        ([`load_or_build`][servo.maps.build.load_or_build]).
    max_steps : int, default 600
        Steps before the episode is truncated.
    cross_manifold : bool, default True
        Draw the target on another manifold than the start's.
    randomize : bool, default False
        Draw the lights and colours anew each episode.
    odometry_noise : bool, default True
        Odometry with random-walk drift; False gives noiseless odometry.
    render_mode : {None, "rgb_array"}, default None
        ``"rgb_array"``: [`render`][servo.task.env.ServoEnv.render] draws the top-down map.
    signal_weight : float, default 1.0
        Weight of the F reward.
    success_reward : float, default 1.0
        Reward on arrival.
    collision_penalty : float, default 0.1
        Penalty per step in contact.
    no_return : {"max_range", "inf"}, default "max_range"
        What a scan's beam with no return reads: the maximum range, flagged by the mask, or
        ``+inf``.
    registered_world : {"hallway", "lawn"}, optional
        Set by the registry: the world the env id names, which ``world`` must not contradict.

    Attributes
    ----------
    map : ServoMap
        The map.
    base : NavigationEnv
        The navigation env the robot runs in.
    observation_space, action_space : gymnasium.spaces.Space
        As above.
    max_steps, cross_manifold, signal_weight, success_reward, collision_penalty, render_mode
        The parameters.
    spec : gymnasium.envs.registration.EnvSpec or None
        ``gym.make``'s spec, its ``max_episode_steps`` the env's ``max_steps``.

    Examples
    --------
    >>> import sim  # headless rendering, chosen before anything imports mujoco
    >>> from servo import load_or_build
    >>> from sim.collect import CollectionSettings, collect_dataset
    >>> data = collect_dataset("lawn-40", CollectionSettings(worlds=("lawn",), frames=40),
    ...                        jobs=1, progress=False)  # three drives of 40 frames, ~10 s
    >>> servo_map = load_or_build("lawn", data, cache="servo-maps", progress=False)
    >>> from servo import ServoEnv
    >>> env = ServoEnv("lawn", servo_map, max_steps=5)
    >>> obs, info = env.reset(seed=1)
    >>> sorted(obs)  # doctest: +NORMALIZE_WHITESPACE
    ['image', 'odometry', 'scan', 'scan_valid', 'target_image', 'target_scan',
     'target_scan_valid']
    >>> obs["image"].shape
    (240, 320, 3)
    >>> env.observation_space.contains(obs)
    True
    >>> info["start_manifold"] != info["target_manifold"]
    True
    >>> for _ in range(5):
    ...     obs, reward, terminated, truncated, info = env.step([0.0, 0.5])
    >>> truncated, info["reason"]
    (True, 'time limit')

    See Also
    --------
    servo.ManifoldServo, servo.SignalServo : The controllers that solve it.
    servo.task.RandomPolicy, servo.task.GreedyFProbing, servo.task.OraclePolicy : Baselines.
    servo.evaluate : Episodes run and scored.
    sim.env.NavigationEnv : The plain navigation env it wraps.
    """

    metadata = NavigationEnv.metadata

    def __init__(
        self,
        world: str | None = None,
        servo_map: ServoMap | str | os.PathLike | None = None,
        max_steps: int = MAX_EPISODE_STEPS,
        cross_manifold: bool = True,
        randomize: bool = False,
        odometry_noise: bool = True,
        render_mode: str | None = None,
        signal_weight: float = 1.0,
        success_reward: float = SUCCESS_REWARD,
        collision_penalty: float = COLLISION_PENALTY,
        no_return: str = "max_range",
        registered_world: str | None = None,
    ):
        world = check_world(world, registered_world)
        if render_mode not in (None, *self.metadata["render_modes"]):  # before the map loads
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        if no_return not in NO_RETURN:
            raise ValueError(f"no_return must be one of {NO_RETURN}, got {no_return!r}")
        randomize = check_bool(randomize, "randomize")
        self.max_steps = check_int(max_steps, "max_steps")
        self.signal_weight = check_finite(signal_weight, "signal_weight")
        self.success_reward = check_finite(success_reward, "success_reward")
        self.collision_penalty = check_finite(collision_penalty, "collision_penalty")
        self.cross_manifold = check_bool(cross_manifold, "cross_manifold")
        odometry_noise = check_bool(odometry_noise, "odometry_noise")
        if servo_map is None:
            servo_map = load_or_build(world)
        elif isinstance(servo_map, str | os.PathLike):
            servo_map = load_map(servo_map, world)  # a path keeps vector-env workers cheap
        if not isinstance(servo_map, ServoMap):
            raise TypeError(
                f"servo_map must be a ServoMap, a saved map's path or None, got "
                f"{type(servo_map).__name__}"
            )
        servo_map.check_world(world)
        self.map = servo_map
        self.render_mode = render_mode
        self.base = NavigationEnv(
            world,
            render_mode=render_mode,
            odometry=None if odometry_noise else OdometryConfig.noiseless(),
            randomize=randomize,
            no_return=no_return,
        )
        servo_map.check_world(world, self.base.world.digest)  # the same floor plan too
        if self.base.observation_space["image"].shape != servo_map.image_shape:
            raise MapError(
                f"the map's images are {servo_map.image_shape}, the camera gives "
                f"{self.base.observation_space['image'].shape}"
            )
        b = self.base.observation_space
        self.observation_space = spaces.Dict(
            {
                "image": b["image"],
                **self.base.scan_spaces("scan"),
                "odometry": spaces.Box(-np.inf, np.inf, (3,), np.float64),
                "target_image": b["image"],
                **self.base.scan_spaces("target_scan"),
            }
        )
        self.action_space = self.base.action_space
        self._target = 0
        self._feats_cache: dict = {}

    # -- the registry's spec -----------------------------------------------------------------
    @property
    def spec(self):
        """``gym.make``'s ``EnvSpec`` (None otherwise), ``max_episode_steps`` the ``max_steps``."""
        return spec_with_own_limit(self.__dict__.get("_spec"), self.max_steps)

    @spec.setter
    def spec(self, spec) -> None:
        self._spec = warn_of_map_object(spec)

    # -- task sampling ----------------------------------------------------------------------
    def _map_label(self, manifold: str | None) -> int:
        """Return the map's label of the world's manifold ``manifold``.

        The map's labels index the dataset's manifolds, not the world's ids; -2, which no view
        has, where it has none.
        """
        names = self.map.manifold_names
        return names.index(manifold) if manifold in names else -2

    def _views_on(self, manifold: str) -> np.ndarray:
        names = self.base.world.manifold_names
        if not isinstance(manifold, str) or manifold not in names:
            raise ValueError(
                f"manifold must be one of {names} (the manifolds of the {self.map.world!r} "
                f"world), got {manifold!r}"
            )
        views = np.flatnonzero(self.map.true_labels == self._map_label(manifold))
        if len(views) == 0:
            raise ValueError(f"no stored view on manifold {manifold!r} in the {self.map.world} map")
        return views

    def _start_pose(self, rng, view: int) -> np.ndarray:
        free = self.base.occupancy
        base = self.map.true_poses[view]
        for _ in range(100):
            r, a = START_RADIUS * np.sqrt(rng.uniform()), rng.uniform(-np.pi, np.pi)
            pose = base + (r * np.cos(a), r * np.sin(a), rng.uniform(-START_YAW, START_YAW))
            if free.is_free(pose[:2]) and free.clearance[free.cell_of(pose[:2])] >= 0.35:
                return np.array([pose[0], pose[1], float(wrap_angle(pose[2]))])
        return base.copy()

    def _candidates(self, ok: np.ndarray, options: dict, what: str) -> np.ndarray:
        """Return the views where ``ok``, or raise where there are none.

        None means the options contradict ``cross_manifold`` (e.g. a start manifold that is the
        target's), which is said rather than left to ``rng.integers(0)`` ("high <= 0").
        """
        cands = np.flatnonzero(ok)
        if len(cands) == 0 and not self.cross_manifold:
            raise ValueError(f"the {self.map.world} map has no stored view on a manifold")
        if len(cands) == 0:
            given = {k: options[k] for k in sorted(options) if k in RESET_OPTIONS}
            raise ValueError(
                f"the reset options {given} conflict with cross_manifold=True: no stored view "
                f"{what} on another manifold; choose other options or pass "
                "ServoEnv(cross_manifold=False)"
            )
        return cands

    def _sample_task(self, rng, options: dict) -> tuple[np.ndarray, int]:
        m = self.map
        if "target" in options:
            target = m.check_view(options["target"], "options['target']")
        elif "target_manifold" in options:
            views = self._views_on(options["target_manifold"])
            target = int(views[rng.integers(len(views))])
        else:
            target = None
        if "pose" in options:
            pose = check_pose_option(options["pose"])
        else:
            if "start_view" in options:
                start = m.check_view(options["start_view"], "options['start_view']")
            else:
                labels = m.true_labels
                ok = labels >= 0
                if "start_manifold" in options:
                    self._views_on(options["start_manifold"])  # validates the name
                    ok &= labels == self._map_label(options["start_manifold"])
                if target is not None and self.cross_manifold:
                    ok &= labels != labels[target]
                cands = self._candidates(ok, options, "to start from")
                start = int(cands[rng.integers(len(cands))])
            pose = self._start_pose(rng, start)
        if target is None:
            here = int(self.base.world.manifold_at(pose[:2]))
            if here >= 0:
                here = self._map_label(self.base.world.manifolds.name_of(here))
            ok = self.map.true_labels >= 0
            if self.cross_manifold:
                ok &= self.map.true_labels != here
            cands = self._candidates(ok, options, "to target")
            target = int(cands[rng.integers(len(cands))])
        return pose, target

    def _junctions_between(self, start: str | None, target: int) -> int | None:
        """Count the junctions between the start's manifold and the target view's.

        For evaluation only; None where either is on no manifold of the world.
        """
        world, end = getattr(self.base, "world", None), self.map.true_manifold(target)
        if world is None or start is None or end not in world.manifold_ids:  # None: a stand-in
            return None
        return world.junctions_between(start, end)

    # -- signal -----------------------------------------------------------------------------
    def _signal(self, image: np.ndarray) -> float:
        """F^j(k) of eq. 13 toward the target view, in the target's cluster."""
        m = self.map
        x = m.image_features.transform(image[None]).astype(np.float32)
        # one BLAS thread whatever the machine's load: two (mapping.validation.busy) would
        # change the reward's last bits, and an episode must be the same for the same seed
        with single_threaded_blas():
            return float(m.clustering.signal(x, int(m.clusters[self._target]), self._target)[0])

    # -- gymnasium API ----------------------------------------------------------------------
    def _obs(self, base_obs: dict, odometry: np.ndarray) -> dict:
        return {
            **base_obs,
            "odometry": se2_relative(self._odo0, odometry),
            # Copies: a caller may keep or modify what it gets (check_env tests this).
            "target_image": self.map.images[self._target].copy(),
            **self.base.scan_observation(self.map.scans[self._target], "target_scan"),
        }

    def _progress(self, info: dict) -> dict:
        rel = se2_relative(self._target_pose, info["pose"])
        info.update(
            target_view=self._target,
            target_pose=self._target_pose.copy(),
            start_manifold=self._start_manifold,
            target_manifold=self.map.true_manifold(self._target),
            junctions=self._junctions,
            distance=float(np.hypot(rel[0], rel[1])),
            heading_error=float(abs(rel[2])),
            path_length=self._path_length,
        )
        info["success"] = bool(
            info["distance"] <= SUCCESS_RADIUS and info["heading_error"] <= SUCCESS_HEADING
        )
        return info

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode: start and target as ``options`` say (see the class), from ``seed``.

        Parameters
        ----------
        seed : int, optional
            The seed of the env's generator (Gymnasium's ``reset``).
        options : dict, optional
            The reset options of the class: ``target``, ``target_manifold``, ``start_view``,
            ``start_manifold`` or ``pose``.

        Returns
        -------
        observation : dict
            The first observation.
        info : dict
            The first info.
        """
        super().reset(seed=seed)
        options = check_keys(options, RESET_OPTIONS, "options")
        task_rng, base_seed = self.np_random.spawn(1)[0], int(self.np_random.integers(2**31))
        pose, self._target = self._sample_task(task_rng, options)
        obs, info = self.base.reset(seed=base_seed, options={"pose": pose})
        self._target_pose = self.map.true_poses[self._target].copy()
        self._start_manifold = info["manifold"]
        self._junctions = self._junctions_between(info["manifold"], self._target)
        self._odo0 = info["odometry"].copy()
        self._steps = 0
        self._path_length = 0.0
        self._recent: list[np.ndarray] = [info["pose"][:2]]
        self._contacts = 0
        self._f_target = max(self._signal(self.map.images[self._target]), 1e-12)
        self._f = self._signal(obs["image"]) / self._f_target
        info = self._progress(info)
        info.update(signal=self._f, reason=None)
        return self._obs(obs, info["odometry"]), info

    def step(self, action):
        """Hold ``action`` (v, omega) for one control step; the usual Gymnasium five-tuple.

        Parameters
        ----------
        action : array_like of shape (2,)
            The command (v m/s, omega rad/s).

        Returns
        -------
        observation : dict
            The observation after the step.
        reward : float
            The sum of the reward parts.
        terminated : bool
            Success, or stuck.
        truncated : bool
            ``max_steps`` reached.
        info : dict
            The step's info, with ``reason``.
        """
        before = self.base.sim.pose
        obs, _, _, _, info = self.base.step(action)
        self._steps += 1
        self._path_length += float(np.hypot(*(info["pose"][:2] - before[:2])))
        info = self._progress(info)
        f = self._signal(obs["image"]) / self._f_target
        parts = {
            "reward_signal": self.signal_weight * (f - self._f),
            "reward_success": self.success_reward if info["success"] else 0.0,
            "reward_collision": -self.collision_penalty if info["collision"] else 0.0,
        }
        self._f = f
        self._contacts = self._contacts + 1 if info["collision"] else 0
        self._recent = (self._recent + [info["pose"][:2]])[-STUCK_WINDOW:]
        stuck = (
            self._contacts >= STUCK_WINDOW
            and np.hypot(*(self._recent[-1] - self._recent[0])) < STUCK_DISTANCE
        )
        terminated = info["success"] or stuck
        truncated = not terminated and self._steps >= self.max_steps
        reason = None
        if terminated or truncated:
            reason = "success" if info["success"] else "stuck" if stuck else "time limit"
        info.update(parts, signal=f, reason=reason, stuck=bool(stuck))
        reward = float(sum(parts.values()))
        return self._obs(obs, info["odometry"]), reward, terminated, truncated, info

    def render(self):
        """Draw the top-down map: robot, laser, trail and target.

        Returns
        -------
        ndarray of shape (H, W, 3) or None
            The image with ``render_mode="rgb_array"``, else None.
        """
        if self.render_mode != "rgb_array":
            return None
        return self.base.draw(target=self._target_pose)

    def close(self):
        """Free renderers; safe to call twice."""
        base = getattr(self, "base", None)
        if base is not None:
            base.close()

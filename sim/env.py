"""The plain navigation env: drive the robot in a world and see what its sensors see."""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from common.validation import CheckedKeywords, check_bool, check_finite, check_keys
from scenes import NO_MANIFOLD, build_world
from scenes.families import check_world_name, parse_world_name
from scenes.robot import RADIUS
from sim.camera import CameraConfig
from sim.laser import LaserConfig
from sim.odometry import OdometryConfig
from sim.randomize import AppearanceRandomizer
from sim.simulator import OMEGA_LIMIT, V_LIMITS, Simulator
from sim.topdown import TopDownView

SENSORS = ("image", "scan")
NO_RETURN = ("max_range", "inf")  # what a beam with no return reads in the observation
RESET_OPTIONS = ("pose", "manifold")
START_CLEARANCE = 0.45  # m from any obstacle for a sampled start pose
COLLISION_PENALTY = 1.0


def sensor_config(value, cls, name: str):
    """Turn ``value`` into an instance of the sensor dataclass ``cls``.

    ``cls`` is ``CameraConfig``, ``LaserConfig`` or ``OdometryConfig``: None gives the
    default, a dict its fields (a spec that stays JSON); anything else, or an unknown field,
    an error naming ``name``.

    Parameters
    ----------
    value : cls, dict or None
        The configuration, a dict of its fields, or None.
    cls : type
        The dataclass.
    name : str
        The parameter's name, for the error.

    Returns
    -------
    cls
        The configuration.
    """
    if value is None:
        return cls()
    if isinstance(value, cls):
        return value
    if isinstance(value, Mapping):
        fields = tuple(f.name for f in dataclasses.fields(cls))
        return cls(**check_keys(value, fields, name))
    raise TypeError(
        f"{name} must be a {cls.__name__}, a dict of its fields or None, got {type(value).__name__}"
    )


def check_world(world, registered_world) -> str:
    """Return the world to build, normalised.

    It is ``world``, else the one the env id names (``registered_world``, passed by the
    registry), else "hallway". A generated world (``FAMILY:SEED``) must be of the id's family;
    a ``world`` that contradicts the id is an error rather than the other world under the id's
    name.

    Parameters
    ----------
    world : str or None
        The world asked for.
    registered_world : str or None
        The world the env id names.

    Returns
    -------
    str
        The world's name.
    """
    world = None if world is None else check_world_name(world, "world")
    if registered_world is not None:
        registered_world = check_world_name(registered_world, "registered_world")
    if world is not None and registered_world is not None and world != registered_world:
        family, registered = parse_world_name(world).family, parse_world_name(registered_world)
        if registered.canonical and family == registered.family:
            return world  # a generated world of the id's family
        raise ValueError(
            f"world={world!r} contradicts the env id, which is the {registered_world} world "
            f"(it takes {registered.family!r} or {registered.family}:SEED); make the {family} "
            "world's id instead of passing world="
        )
    return world or registered_world or "hallway"


def check_sensors(sensors) -> tuple[str, ...]:
    """Check that ``sensors`` holds distinct names from ``SENSORS`` and return them as a tuple.

    A bare string (which would split into letters) is refused, naming the tuple to write.

    Parameters
    ----------
    sensors : iterable of str
        The sensors asked for.

    Returns
    -------
    tuple of str
        The sensors, in the order given.
    """
    if isinstance(sensors, str):
        raise ValueError(
            f"sensors must be a tuple of names from {SENSORS}, got the string {sensors!r}; "
            f"write ({sensors!r},)"
        )
    try:
        sensors = tuple(sensors)
    except TypeError:
        raise ValueError(
            f"sensors must be a tuple of names from {SENSORS}, got {sensors!r}"
        ) from None
    if not sensors or any(s not in SENSORS for s in sensors) or len(set(sensors)) < len(sensors):
        raise ValueError(
            f"sensors must be a non-empty subset of {SENSORS} without repeats, got {sensors}"
        )
    return sensors


def check_pose_option(value) -> np.ndarray:
    """Check ``options['pose']`` of ``reset``: three finite real numbers (x, y, yaw).

    Anything else (None, a string, complex or ragged values) raises a ValueError naming it.
    Shared with ``servo.task.env.ServoEnv``, which samples its task from the pose before this
    env sees it.

    Parameters
    ----------
    value : object
        The option's value.

    Returns
    -------
    ndarray of shape (3,), float64
        The pose.
    """
    try:
        pose = np.asarray(value)
    except (TypeError, ValueError):  # ragged nesting
        pose = np.asarray(None)
    if pose.dtype.kind not in "iuf" or pose.shape != (3,) or not np.all(np.isfinite(pose)):
        raise ValueError(
            f"options['pose'] must be a finite (x, y, yaw) of real numbers, got {value!r}"
        )
    return pose.astype(np.float64)


class NavigationEnv(CheckedKeywords, gym.Env):
    """Drive a differential-drive robot through the hallway or lawn world (a Gymnasium env).

    Registered as ``topomap/Hallway-v0`` and ``topomap/Lawn-v0`` when ``sim`` is imported.

    Description
        A robot with a forward camera and a 2-D laser starts at a random free pose (or the one
        given in ``options["pose"]``) and is driven by velocity commands. There is no goal:
        this is the plain env for data collection and for building tasks on (see ``servo``).

    Action Space
        ``Box([-0.5, -1.5], [1.5, 1.5], float32)``: forward speed v (m/s) and turn rate omega
        (rad/s). Out-of-range actions are clipped to these bounds; NaN, inf or a wrong shape
        raise ``ValueError``. Each action is held for ``control_dt`` = 0.1 s.

    Observation Space
        ``Dict(image=Box(0, 255, (H, W, 3), uint8), scan=Box(0, max_range, (beams,), float32),
        scan_valid=MultiBinary(beams))``. ``scan`` ranges are metres; a beam with no return
        within the laser's maximum range reads ``max_range`` and has ``scan_valid`` 0 (1 where
        it returned), so every observation is finite and inside its bounds, as RL libraries and
        Gymnasium's normalising wrappers need. ``no_return="inf"`` gives the raw ranges instead:
        ``scan=Box(0, inf)`` with ``+inf`` for no return (REP 117) and no ``scan_valid``.
        ``sensors`` selects which keys are present (a laser-only env never renders).

    Rewards
        ``-collision_penalty`` on a step where the robot touches an obstacle, else ``0``
        (``info["reward_collision"]``).

    Episode End
        Never terminates; truncated by the registered ``max_episode_steps`` (1000).

    Info
        ``pose`` (true x, y, yaw), ``odometry`` (noisy pose), ``manifold`` (name or None),
        ``manifold_id``, ``collision``, ``time``: truth is for evaluation only.

    Hooks for tasks built on it (``servo.ServoEnv``)
        ``occupancy`` (the free-space grid of the world), ``sample_pose`` and ``draw(target=)``
        (the top-down map, optionally with a target pose outlined).

    Version History
        v0: initial version.

    Parameters
    ----------
    world : str, optional
        The world: ``"hallway"``, ``"lawn"`` or a generated world ``FAMILY:SEED`` of the id's
        family (``gym.make("topomap/Hallway-v0", world="hallway:17")``); default the one the
        env id names, else "hallway". A world that contradicts the id
        (``gym.make("topomap/Hallway-v0", world="lawn")`` or ``world="lawn:3"``) raises
        ``ValueError``. ``options["manifold"]`` and ``info["manifold"]`` name the world's own
        manifolds (``info["manifold_id"]`` is the world's label id).
    render_mode : {None, "rgb_array"}, default None
        ``"rgb_array"``: [`render`][sim.env.NavigationEnv.render] draws a top-down map with the
        robot, its laser and its trail.
    camera : CameraConfig or dict, optional
        The camera, or a dict of its fields (``{"width": 160, "height": 120}``: a spec that
        stays JSON); default ``CameraConfig()`` (320 x 240, 45 degrees vertical field of view).
    laser : LaserConfig or dict, optional
        The laser, or a dict of its fields; default ``LaserConfig()`` (361 beams over 180
        degrees, 20 m).
    odometry : OdometryConfig or dict, optional
        The odometry's drift, or a dict of its fields; default ``OdometryConfig()``.
    sensors : tuple of {"image", "scan"}, default ("image", "scan")
        The sensors whose observations are given (a tuple: ``("scan",)``, not ``"scan"``).
    randomize : bool, default False
        Draw the lights and colours anew at each reset.
    collision_penalty : float, default 1.0
        Penalty on a step in contact.
    appearance : {"default", "hard"}, default "default"
        ``"hard"``: every branch in the main manifold's materials.
    no_return : {"max_range", "inf"}, default "max_range"
        What a beam with no return reads: the maximum range, flagged by ``scan_valid``, or
        ``+inf``.
    registered_world : {"hallway", "lawn"}, optional
        Set by the registry: the world the env id names, which ``world`` must not contradict.

    Attributes
    ----------
    world : scenes.World
        The world with its ground truth.
    sim : Simulator
        The simulator.
    occupancy
        The world's free-space grid (5 cm cells), for start poses.
    observation_space, action_space : gymnasium.spaces.Space
        As above.
    world_name, render_mode, sensors, randomize, collision_penalty, no_return
        The parameters.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import sim  # registers the envs; headless rendering before mujoco loads
    >>> env = gym.make("topomap/Lawn-v0", sensors=("scan",))
    >>> obs, info = env.reset(seed=0)
    >>> obs["scan"].shape, obs["scan_valid"].shape, info["manifold"].startswith("lawn")
    ((361,), (361,), True)
    >>> obs, reward, terminated, truncated, info = env.step([0.5, 0.0])
    >>> terminated, sorted(obs), env.observation_space.contains(obs)
    (False, ['scan', 'scan_valid'], True)
    >>> env.close()

    See Also
    --------
    servo.ServoEnv : The servo task built on it.
    sim.simulator.Simulator : The robot and its sensors.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}

    def __init__(
        self,
        world: str | None = None,
        render_mode: str | None = None,
        camera: CameraConfig | Mapping | None = None,
        laser: LaserConfig | Mapping | None = None,
        odometry: OdometryConfig | Mapping | None = None,
        sensors: tuple[str, ...] = SENSORS,
        randomize: bool = False,
        collision_penalty: float = COLLISION_PENALTY,
        appearance: str = "default",
        no_return: str = "max_range",
        registered_world: str | None = None,
    ):
        world = check_world(world, registered_world)
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(
                f"render_mode must be None or one of {self.metadata['render_modes']}, "
                f"got {render_mode!r}"
            )
        sensors = check_sensors(sensors)
        if no_return not in NO_RETURN:
            raise ValueError(f"no_return must be one of {NO_RETURN}, got {no_return!r}")
        self.world_name = world
        self.render_mode = render_mode
        self.sensors = sensors
        self.randomize = check_bool(randomize, "randomize")
        self.collision_penalty = check_finite(collision_penalty, "collision_penalty")
        self.no_return = no_return
        self.camera_config = sensor_config(camera, CameraConfig, "camera")
        self.laser_config = sensor_config(laser, LaserConfig, "laser")
        odometry = sensor_config(odometry, OdometryConfig, "odometry")
        self.world = build_world(world, appearance=appearance)
        self.sim = Simulator(
            self.world,
            self.camera_config if "image" in sensors else None,
            self.laser_config if "scan" in sensors else None,
            odometry,
        )
        self._randomizer = AppearanceRandomizer(self.sim.model)
        obs = {}
        if "image" in sensors:
            c = self.camera_config
            obs["image"] = spaces.Box(0, 255, (c.height, c.width, 3), np.uint8)
        if "scan" in sensors:
            obs.update(self.scan_spaces("scan"))
        self.observation_space = spaces.Dict(obs)
        self.action_space = spaces.Box(
            np.array([V_LIMITS[0], -OMEGA_LIMIT], np.float32),
            np.array([V_LIMITS[1], OMEGA_LIMIT], np.float32),
        )
        self.occupancy = self.world.free_space(0.05)  # the walkable floor, for start poses
        self._view: TopDownView | None = None
        self._trail: list[np.ndarray] = []
        self._last_scan: np.ndarray | None = None
        self._noise_rng = np.random.default_rng(0)

    # -- helpers ----------------------------------------------------------------------------
    def scan_spaces(self, key: str) -> dict[str, spaces.Space]:
        """Build the observation's spaces of a scan under ``key``.

        ``no_return="max_range"`` gives ``Box(0, max_range)`` and its mask ``{key}_valid``;
        ``"inf"`` ``Box(0, inf)`` alone.

        Parameters
        ----------
        key : str
            The observation key of the scan.

        Returns
        -------
        dict of str to gymnasium.spaces.Space
            The scan's space and, with ``no_return="max_range"``, its mask's.
        """
        beams = self.laser_config.beams
        if self.no_return == "inf":
            return {key: spaces.Box(0.0, np.inf, (beams,), np.float32)}
        high = np.float32(self.laser_config.max_range)
        return {
            key: spaces.Box(0.0, high, (beams,), np.float32),
            f"{key}_valid": spaces.MultiBinary(beams),
        }

    def scan_observation(self, ranges: np.ndarray, key: str) -> dict[str, np.ndarray]:
        """Turn ``ranges`` into the observation's entries of a scan.

        The entries are those of [`scan_spaces`][sim.env.NavigationEnv.scan_spaces]: a copy,
        with no return (and a return pushed past the maximum range by the range noise) at the
        maximum range and ``{key}_valid`` 1 where the beam returned; with ``no_return="inf"``
        the ranges alone.

        Parameters
        ----------
        ranges : ndarray of shape (beams,)
            The laser's ranges, m; +inf: no return.
        key : str
            The observation key of the scan.

        Returns
        -------
        dict of str to ndarray
            The scan (float32) and, with ``no_return="max_range"``, its mask (int8).
        """
        if self.no_return == "inf":
            return {key: np.array(ranges, np.float32)}
        valid = np.isfinite(ranges)
        high = np.float32(self.laser_config.max_range)
        clipped = np.where(valid, np.minimum(ranges, high), high).astype(np.float32)
        return {key: clipped, f"{key}_valid": valid.astype(np.int8)}

    def sample_pose(self, rng: np.random.Generator, manifold: str | None = None) -> np.ndarray:
        """Draw a random pose at least ``START_CLEARANCE`` from obstacles, on ``manifold`` if given.

        Parameters
        ----------
        rng : numpy.random.Generator
            Draws the cell and the heading.
        manifold : str, optional
            A manifold of the world to start on.

        Returns
        -------
        ndarray of shape (3,)
            The pose ``(x, y, yaw)``.
        """
        ok = self.occupancy.clearance >= START_CLEARANCE
        centers = self.occupancy.cell_centers()
        if manifold is not None:
            ids = self.world.manifold_ids
            if not isinstance(manifold, str) or manifold not in ids:
                raise ValueError(
                    f"manifold must be one of {self.world.manifold_names} (the manifolds of "
                    f"{self.world_name!r}), got {manifold!r}"
                )
            ok &= self.world.manifold_at(centers) == ids[manifold]
        cells = np.argwhere(ok)
        if len(cells) == 0:
            raise ValueError(
                f"no free start pose on manifold {manifold!r} in world {self.world_name!r}"
            )
        i, j = cells[rng.integers(len(cells))]
        x, y = centers[i, j]
        return np.array([x, y, rng.uniform(-np.pi, np.pi)])

    def _observe(self) -> dict[str, np.ndarray]:
        obs = {}
        if "image" in self.sensors:
            obs["image"] = self.sim.render()
        if "scan" in self.sensors:
            self._last_scan = self.sim.scan(self._noise_rng)
            obs.update(self.scan_observation(self._last_scan, "scan"))
        return obs

    def _info(self, collision: bool = False) -> dict[str, Any]:
        pose = self.sim.pose
        label = int(self.world.manifold_at(pose[:2]))
        return {
            "pose": pose,
            "odometry": self.sim.odometry.pose.copy(),
            "manifold": None if label == NO_MANIFOLD else self.world.manifolds.name_of(label),
            "manifold_id": label,
            "collision": bool(collision),
            "time": self.sim.time,
        }

    # -- gymnasium API ----------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Place the robot at ``options["pose"]``, else at a free pose drawn from ``seed``.

        The drawn pose lies on ``options["manifold"]`` when given; ``randomize`` draws the
        lights and colours anew.

        Parameters
        ----------
        seed : int, optional
            Seeds the env's random generator.
        options : dict, optional
            None or a dict with keys from ``RESET_OPTIONS`` (an unknown key is an error naming
            the closest known one).

        Returns
        -------
        observation : dict of str to ndarray
            The first observation.
        info : dict
            The true pose, odometry and manifold, as in a step's info.
        """
        super().reset(seed=seed)
        options = check_keys(options, RESET_OPTIONS, "options")
        rng = self.np_random
        self._noise_rng, odo_rng, look_rng = rng.spawn(3)
        self._randomizer.apply(look_rng if self.randomize else None)
        if "pose" in options:
            pose = check_pose_option(options["pose"])
            if (
                not self.occupancy.is_free(pose[:2])
                or self.occupancy.clearance[self.occupancy.cell_of(pose[:2])] < RADIUS
            ):
                raise ValueError(f"options['pose'] {tuple(pose)} is not in free space")
        else:
            pose = self.sample_pose(rng, options.get("manifold"))
        self.sim.reset(pose, odo_rng)
        self._trail = [self.sim.pose]
        return self._observe(), self._info()

    def step(self, action):
        """Hold ``action`` (v, omega) for one control step; return the usual Gymnasium five-tuple.

        Parameters
        ----------
        action : array-like of shape (2,)
            ``(v, omega)``, finite; clipped to the action space.

        Returns
        -------
        observation : dict of str to ndarray
            The sensors' observation.
        reward : float
            ``-collision_penalty`` on contact, else 0.
        terminated, truncated : bool
            Always False.
        info : dict
            The true pose, odometry, manifold, collision, time and ``reward_collision``.
        """
        a = np.asarray(action, dtype=np.float64)
        if a.shape != (2,):
            raise ValueError(f"action must have shape (2,) = (v, omega), got shape {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"action must be finite, got {action!r}")
        a = np.clip(a, self.action_space.low, self.action_space.high)
        collision = self.sim.step(a[0], a[1])
        self._trail.append(self.sim.pose)
        reward = -self.collision_penalty if collision else 0.0
        info = self._info(collision)
        info["reward_collision"] = reward
        return self._observe(), reward, False, False, info

    def draw(self, target=None) -> np.ndarray:
        """Draw the top-down map.

        It shows the regions, the robot, its last scan, its trail since the reset and, if
        given, a ``target`` pose in outline.

        Parameters
        ----------
        target : array-like of shape (3,), optional
            A pose ``(x, y, yaw)`` to outline.

        Returns
        -------
        ndarray of shape (H, W, 3), uint8
            The RGB map.
        """
        if self._view is None:
            self._view = TopDownView(self.world)
        return self._view.draw(
            self.sim.pose,
            self._last_scan,
            self.laser_config.angles,
            np.asarray(self._trail),
            target=target,
        )

    def render(self):
        """Render the top-down map: robot, laser and trail (``"rgb_array"``), else None.

        Returns
        -------
        ndarray of shape (H, W, 3), uint8, or None
            The map in ``"rgb_array"`` mode, else None.
        """
        if self.render_mode != "rgb_array":
            return None
        return self.draw()

    def close(self):
        """Free renderers; safe to call twice."""
        sim = getattr(self, "sim", None)
        if sim is not None:
            sim.close()

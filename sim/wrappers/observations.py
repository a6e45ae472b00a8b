"""Observation wrappers for reinforcement learning: one ``Box`` from the envs' ``Dict``.

The navigation and servo envs observe a ``Dict`` (camera image, laser scan and its mask, and
for the servo task the odometry and the target's view). Gymnasium's image and normalising
wrappers and Stable-Baselines3's ``CnnPolicy`` / ``MlpPolicy`` take one ``Box``; these
wrappers give it:

- `ImageObservation`: the camera image alone (uint8), optionally resized and grayscale
  (``size=(84, 84), grayscale=True``: what Atari-style CNNs take), and, for the servo task,
  the target's image beside it;
- `ScanObservation`: the laser ranges alone (float32, metres), optionally reduced to fewer
  beams;
- `ScanOdometryObservation`: a small float32 vector of the reduced scan (and the target's,
  for the servo task) over the maximum range, and the odometry pose since the episode's start.

Each works on any env whose observation has the keys it reads (``gym.make`` of the four ids,
with the ``TimeLimit`` and other wrappers the registry adds).
"""

from __future__ import annotations

import cv2
import gymnasium as gym
import numpy as np
from gymnasium import spaces

from common.geometry import se2_relative
from common.validation import check_bool, check_int

IMAGE_KEYS = ("image", "target_image")


def _dict_space(env: gym.Env, wrapper: str, keys: tuple[str, ...]) -> spaces.Dict:
    """Return the env's ``Dict`` observation space, checked to hold ``keys``."""
    space = env.observation_space
    if not isinstance(space, spaces.Dict):
        raise TypeError(
            f"{wrapper} wraps an env with a Dict observation (a topomap env), got "
            f"{type(space).__name__}"
        )
    missing = [k for k in keys if k not in space.spaces]
    if missing:
        raise ValueError(
            f"{wrapper} needs the observation keys {missing}, which this env lacks "
            f"(it has {sorted(space.spaces)})"
        )
    return space


def _max_range(space: spaces.Dict, key: str, wrapper: str) -> float:
    high = float(space[key].high.max())
    if not np.isfinite(high):
        raise ValueError(
            f"{wrapper} needs finite ranges: make the env with no_return='max_range' (the default)"
        )
    return high


def _beam_groups(total: int, beams) -> np.ndarray | None:
    """Return the first beam of each of ``beams`` contiguous groups of ``total`` beams.

    None keeps every beam.
    """
    if beams is None:
        return None
    beams = check_int(beams, "beams")
    if beams > total:
        raise ValueError(f"beams must be at most the laser's {total} beams, got {beams}")
    return np.linspace(0, total, beams, endpoint=False).astype(np.intp)


def _reduce(ranges: np.ndarray, starts: np.ndarray | None) -> np.ndarray:
    """Return the nearest range of each group of beams (a wall seen by any beam stays seen)."""
    return ranges if starts is None else np.minimum.reduceat(ranges, starts)


class ImageObservation(gym.ObservationWrapper, gym.utils.RecordConstructorArgs):
    """The camera image alone, optionally resized and grayscale, as one uint8 ``Box``.

    Parameters
    ----------
    env : gymnasium.Env
        A topomap env (its observation a ``Dict`` with the ``keys``).
    keys : tuple of {"image", "target_image"}, default ("image",)
        The images, side by side from left to right (``("image", "target_image")`` on a
        servo env: the camera and the target's view in one image, which a CNN takes).
    size : (int, int) or None, default None
        (height, width) of each image, resized by area averaging; None keeps the camera's.
    grayscale : bool, default False
        One channel (luma) instead of three.

    Attributes
    ----------
    observation_space : gymnasium.spaces.Box
        ``Box(0, 255, (height, width * len(keys), channels), uint8)``: what Gymnasium's
        ``ResizeObservation``, ``GrayscaleObservation`` (of a colour image),
        ``FrameStackObservation`` and ``NormalizeObservation`` and Stable-Baselines3's
        ``CnnPolicy`` take without options.
    keys, size, grayscale
        The parameters.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import sim
    >>> from sim.wrappers import ImageObservation
    >>> env = ImageObservation(gym.make("topomap/Lawn-v0"), size=(84, 84), grayscale=True)
    >>> obs, _ = env.reset(seed=0)
    >>> obs.shape, obs.dtype, env.observation_space.contains(obs)
    ((84, 84, 1), dtype('uint8'), True)
    >>> env.close()

    See Also
    --------
    sim.wrappers.ScanOdometryObservation : A small vector for an ``MlpPolicy``.
    """

    def __init__(self, env: gym.Env, keys=("image",), size=None, grayscale: bool = False):
        gym.utils.RecordConstructorArgs.__init__(self, keys=keys, size=size, grayscale=grayscale)
        gym.ObservationWrapper.__init__(self, env)
        if isinstance(keys, str) or not keys or any(k not in IMAGE_KEYS for k in keys):
            raise ValueError(
                f"keys must be a non-empty tuple of names from {IMAGE_KEYS}, got {keys!r}"
            )
        self.keys = tuple(keys)
        space = _dict_space(env, "ImageObservation", self.keys)
        h, w = space[self.keys[0]].shape[:2]
        if size is not None:
            if not isinstance(size, tuple | list) or len(size) != 2:
                raise ValueError(f"size must be (height, width) or None, got {size!r}")
            h, w = (check_int(s, "size") for s in size)
        self.size = (h, w)
        self.grayscale = check_bool(grayscale, "grayscale")
        channels = 1 if self.grayscale else 3
        self.observation_space = spaces.Box(0, 255, (h, w * len(self.keys), channels), np.uint8)

    def _one(self, image: np.ndarray) -> np.ndarray:
        h, w = self.size
        if image.shape[:2] != (h, w):
            image = cv2.resize(image, (w, h), interpolation=cv2.INTER_AREA)
        if self.grayscale:
            image = cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)[:, :, None]
        return image

    def observation(self, observation: dict) -> np.ndarray:
        """Put the images of ``keys``, each resized and converted, side by side.

        Parameters
        ----------
        observation : dict of str to ndarray
            The env's observation.

        Returns
        -------
        ndarray of shape (height, width * len(keys), channels), uint8
            The images.
        """
        images = [self._one(observation[k]) for k in self.keys]
        return np.ascontiguousarray(np.concatenate(images, axis=1), dtype=np.uint8)


class ScanObservation(gym.ObservationWrapper, gym.utils.RecordConstructorArgs):
    """The laser ranges alone, in metres, as one float32 ``Box``.

    A beam with no return reads the maximum range (the envs' default ``no_return``), so the
    mask is left out: the ranges alone say it.

    Parameters
    ----------
    env : gymnasium.Env
        A topomap env with a ``scan`` (not ``sensors=("image",)`` nor ``no_return="inf"``).
    beams : int or None, default None
        Reduce the scan to this many contiguous groups of beams, each its nearest range;
        None keeps every beam (361 by default).

    Attributes
    ----------
    observation_space : gymnasium.spaces.Box
        ``Box(0, max_range, (beams,), float32)``: what Gymnasium's ``NormalizeObservation``
        and ``FrameStackObservation``, and Stable-Baselines3's ``MlpPolicy`` and
        ``VecNormalize`` take without options.
    beams : int
        The beams of the observation.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import sim
    >>> from sim.wrappers import ScanObservation
    >>> env = ScanObservation(gym.make("topomap/Lawn-v0", sensors=("scan",)), beams=36)
    >>> obs, _ = env.reset(seed=0)
    >>> obs.shape, obs.dtype, env.observation_space.contains(obs)
    ((36,), dtype('float32'), True)
    >>> env.close()

    See Also
    --------
    sim.wrappers.ScanOdometryObservation : The scan with the odometry.
    """

    def __init__(self, env: gym.Env, beams=None):
        gym.utils.RecordConstructorArgs.__init__(self, beams=beams)
        gym.ObservationWrapper.__init__(self, env)
        space = _dict_space(env, "ScanObservation", ("scan",))
        high = _max_range(space, "scan", "ScanObservation")
        self._starts = _beam_groups(space["scan"].shape[0], beams)
        self.beams = space["scan"].shape[0] if self._starts is None else len(self._starts)
        self.observation_space = spaces.Box(0.0, high, (self.beams,), np.float32)

    def observation(self, observation: dict) -> np.ndarray:
        """Return the (reduced) ranges.

        Parameters
        ----------
        observation : dict of str to ndarray
            The env's observation.

        Returns
        -------
        ndarray of shape (beams,), float32
            The ranges, m.
        """
        return _reduce(np.asarray(observation["scan"], np.float32), self._starts)


class ScanOdometryObservation(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """A small float32 vector: the reduced scan over the maximum range, and the odometry.

    The vector is the scan reduced to ``beams`` groups (each its nearest range) divided by
    the laser's maximum range (so in [0, 1]); on a servo env the target's scan likewise;
    then the odometry pose since the episode's start as (x, y, cos yaw, sin yaw), metres
    (what wheel encoders give, from ``info["odometry"]``; never the true pose).

    Parameters
    ----------
    env : gymnasium.Env
        A topomap env with a ``scan`` and ``info["odometry"]`` (all four ids).
    beams : int or None, default 36
        Groups of beams the scan (and the target's) is reduced to; None keeps every beam.

    Attributes
    ----------
    observation_space : gymnasium.spaces.Box
        ``Box(-inf, inf, (n,), float32)``, ``n = beams`` (+ ``beams`` with a target scan)
        ``+ 4``: what ``NormalizeObservation``, ``FrameStackObservation``, ``MlpPolicy`` and
        ``VecNormalize`` take without options.
    beams : int
        The parameter.
    keys : tuple of str
        The scans in the vector, in order: ``("scan",)`` or ``("scan", "target_scan")``.

    Examples
    --------
    >>> import gymnasium as gym
    >>> import numpy as np
    >>> import sim
    >>> from sim.wrappers import ScanOdometryObservation
    >>> env = ScanOdometryObservation(gym.make("topomap/Lawn-v0", sensors=("scan",)))
    >>> obs, _ = env.reset(seed=0)
    >>> obs.shape, obs.dtype, bool(np.allclose(obs[-4:], [0, 0, 1, 0]))  # x, y, cos, sin
    ((40,), dtype('float32'), True)
    >>> env.close()

    See Also
    --------
    sim.wrappers.ScanObservation : The ranges alone, in metres.
    """

    def __init__(self, env: gym.Env, beams=36):
        gym.utils.RecordConstructorArgs.__init__(self, beams=beams)
        gym.Wrapper.__init__(self, env)
        space = _dict_space(env, "ScanOdometryObservation", ("scan",))
        self.keys = ("scan", "target_scan") if "target_scan" in space.spaces else ("scan",)
        self._scale = 1.0 / _max_range(space, "scan", "ScanOdometryObservation")
        self._starts = _beam_groups(space["scan"].shape[0], beams)
        self.beams = space["scan"].shape[0] if self._starts is None else len(self._starts)
        n = self.beams * len(self.keys) + 4
        self.observation_space = spaces.Box(-np.inf, np.inf, (n,), np.float32)
        self._start = np.zeros(3)

    def _vector(self, observation: dict, info: dict) -> np.ndarray:
        pose = se2_relative(self._start, np.asarray(info["odometry"], np.float64))
        parts = [
            _reduce(np.asarray(observation[k], np.float32), self._starts) * self._scale
            for k in self.keys
        ]
        parts.append(np.array([pose[0], pose[1], np.cos(pose[2]), np.sin(pose[2])]))
        return np.concatenate(parts).astype(np.float32)

    def reset(self, *, seed=None, options=None):
        """Reset the env; the odometry counts from here.

        Parameters
        ----------
        seed : int, optional
            Passed to the env's reset.
        options : dict, optional
            Passed to the env's reset.

        Returns
        -------
        observation : ndarray, float32
            The vector.
        info : dict
            The env's info.
        """
        observation, info = self.env.reset(seed=seed, options=options)
        self._start = np.asarray(info["odometry"], np.float64).copy()
        return self._vector(observation, info), info

    def step(self, action):
        """Step the env; return its five-tuple with the observation as the vector.

        Parameters
        ----------
        action : array-like
            Passed to the env's step.

        Returns
        -------
        observation : ndarray, float32
            The vector.
        reward : float
            The env's reward.
        terminated, truncated : bool
            The env's flags.
        info : dict
            The env's info.
        """
        observation, reward, terminated, truncated, info = self.env.step(action)
        return self._vector(observation, info), reward, terminated, truncated, info

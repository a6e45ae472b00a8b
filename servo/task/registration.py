"""Gymnasium registration of the servo tasks, and the wrapper that names a truncation's reason.

The tasks are registered with string entry points; the wrapper names the reason of a truncation
by an outer ``TimeLimit``.
"""

from __future__ import annotations

import dataclasses
import warnings

import gymnasium as gym
from gymnasium.envs.registration import WrapperSpec

from sim.registration import register_per_world

# ServoEnv's default max_steps: 60 s of simulated time, ~3x the longest cross-manifold route
MAX_EPISODE_STEPS = 600


class TruncationReason(gym.Wrapper, gym.utils.RecordConstructorArgs):
    """Say why an episode was truncated when a ``TimeLimit`` below cut it.

    A [`ServoEnv`][servo.task.env.ServoEnv] names the end of its episodes in ``info["reason"]``
    ("success", "stuck", "time limit"), but a ``gymnasium.wrappers.TimeLimit`` around it (what
    ``gym.make(..., max_episode_steps=n)`` adds) truncates without the env knowing, which left
    the reason None. This wrapper, put on top of the ``TimeLimit``, sets ``info["reason"]`` to
    "time limit" on a truncated step whose reason is None; every other step passes unchanged.
    The registered servo ids carry it (``gym.make`` adds it above any ``TimeLimit``); wrap it
    yourself over a ``TimeLimit`` of your own.

    Parameters
    ----------
    env : gymnasium.Env
        The env (with its ``TimeLimit``) whose truncations to name.

    Attributes
    ----------
    env : gymnasium.Env
        The wrapped env.

    Examples
    --------
    >>> import gymnasium as gym
    >>> from gymnasium.wrappers import TimeLimit
    >>> from servo.task import TruncationReason
    >>> class Idle(gym.Env):
    ...     observation_space = action_space = gym.spaces.Discrete(1)
    ...     def reset(self, *, seed=None, options=None):
    ...         return 0, {"reason": None}
    ...     def step(self, action):
    ...         return 0, 0.0, False, False, {"reason": None}
    >>> env = TruncationReason(TimeLimit(Idle(), max_episode_steps=2))
    >>> _ = env.reset()
    >>> env.step(0)[3:], env.step(0)[3:]
    ((False, {'reason': None}), (True, {'reason': 'time limit'}))

    See Also
    --------
    servo.task.ServoEnv : The env whose truncations it names.
    gymnasium.wrappers.TimeLimit : The clock it names.
    """

    def __init__(self, env: gym.Env):
        gym.utils.RecordConstructorArgs.__init__(self)
        gym.Wrapper.__init__(self, env)

    def step(self, action):
        """Step the wrapped env, naming the reason of a truncation that had none.

        ``info["reason"]`` is set to ``"time limit"`` on such a truncation.

        Parameters
        ----------
        action : object
            The wrapped env's action.

        Returns
        -------
        observation : object
            The wrapped env's observation.
        reward : float
            Its reward.
        terminated, truncated : bool
            Its episode's end.
        info : dict
            Its info, with the reason of a truncation.
        """
        obs, reward, terminated, truncated, info = self.env.step(action)
        if truncated and not terminated and info.get("reason") is None:
            info = {**info, "reason": "time limit"}
        return obs, reward, terminated, truncated, info


def spec_with_own_limit(spec, max_steps: int):
    """Return ``ServoEnv.spec``: ``gym.make``'s spec, with the env's own step limit.

    ``max_episode_steps`` is set to the env's own limit where the registry set none (the servo
    ids add no ``TimeLimit``: one clock, which names its reason), so tools that read the limit
    from the spec see it.

    Parameters
    ----------
    spec : gymnasium.envs.registration.EnvSpec or None
        The spec ``gym.make`` gave.
    max_steps : int
        The env's own limit.

    Returns
    -------
    gymnasium.envs.registration.EnvSpec or None
        The spec, with ``max_episode_steps`` set.
    """
    if spec is None or spec.max_episode_steps is not None:
        return spec
    return dataclasses.replace(spec, max_episode_steps=max_steps)


def warn_of_map_object(spec):
    """Return ``spec``, after a warning if its ``servo_map`` is a map object, not a path.

    Parameters
    ----------
    spec : gymnasium.envs.registration.EnvSpec or None
        The spec ``gym.make`` gave.

    Returns
    -------
    gymnasium.envs.registration.EnvSpec or None
        ``spec`` itself.
    """
    from servo.maps import ServoMap

    if spec is not None and isinstance(spec.kwargs.get("servo_map"), ServoMap):
        warnings.warn(
            "servo_map was given to gym.make as a ServoMap object: the env's spec now holds "
            "the map's arrays (copied with every wrapper's spec, not writable as JSON); pass "
            "the path of a saved map instead (servo.save_map(m, directory) returns it)",
            UserWarning,
            stacklevel=4,  # the caller of gym.make
        )
    return spec


def register_envs() -> None:
    """Register ``topomap/HallwayServo-v0`` and ``topomap/LawnServo-v0`` with Gymnasium.

    Each id makes a [`ServoEnv`][servo.task.env.ServoEnv] of its world, wrapped in
    [`TruncationReason`][servo.task.registration.TruncationReason].
    """
    # No TimeLimit wrapper: ServoEnv keeps its own clock (max_steps), which also names the
    # reason ("time limit"); a second clock would cut a longer max_steps short. One that the
    # user asks for (max_episode_steps=) gets its reason from TruncationReason above it.
    register_per_world(
        {"topomap/HallwayServo-v0": "hallway", "topomap/LawnServo-v0": "lawn"},
        "servo.task.env:ServoEnv",
        None,
        additional_wrappers=(
            WrapperSpec("TruncationReason", "servo.task.registration:TruncationReason", {}),
        ),
    )

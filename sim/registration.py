"""Gymnasium registration with string entry points: heavy modules load only on ``make``."""

from __future__ import annotations

import gymnasium as gym

MAX_EPISODE_STEPS = 1000


def register_per_world(
    env_ids: dict[str, str],
    entry_point: str,
    max_episode_steps: int | None,
    additional_wrappers: tuple = (),
) -> None:
    """Register one env id per world (``{id: world}``), each once; shared by ``servo``.

    The id's world goes in as ``registered_world``, not ``world``: ``gym.make``'s keyword
    arguments replace the registered ones, so a ``world=`` that contradicts the id could not
    be told from the id's own; the env checks the two agree.

    Parameters
    ----------
    env_ids : dict of str to str
        Env id -> world.
    entry_point : str
        The env's ``"module:Class"``.
    max_episode_steps : int or None
        The ``TimeLimit``; None adds no ``TimeLimit`` wrapper (for envs with their own clock).
    additional_wrappers : tuple, default ()
        ``gymnasium.envs.registration.WrapperSpec`` entries, put on top of the ``TimeLimit``.
    """
    for env_id, world in env_ids.items():
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point=entry_point,
                kwargs={"registered_world": world},
                max_episode_steps=max_episode_steps,
                additional_wrappers=additional_wrappers,
            )


def register_envs() -> None:
    """Register ``topomap/Hallway-v0`` and ``topomap/Lawn-v0``, each once."""
    register_per_world(
        {"topomap/Hallway-v0": "hallway", "topomap/Lawn-v0": "lawn"},
        "sim.env:NavigationEnv",
        MAX_EPISODE_STEPS,
    )

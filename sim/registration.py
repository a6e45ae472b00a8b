"""Gymnasium registration with string entry points: heavy modules load only on ``make``."""

from __future__ import annotations

import gymnasium as gym

MAX_EPISODE_STEPS = 1000


def register_envs() -> None:
    for env_id, world in (("topomap/Hallway-v0", "hallway"), ("topomap/Lawn-v0", "lawn")):
        if env_id not in gym.registry:
            gym.register(
                id=env_id,
                entry_point="sim.env:NavigationEnv",
                kwargs={"world": world},
                max_episode_steps=MAX_EPISODE_STEPS,
            )

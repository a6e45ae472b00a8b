"""Gymnasium registration of the servo tasks with string entry points."""

from __future__ import annotations

from sim.registration import register_per_world

# ServoEnv's default max_steps: 60 s of simulated time, ~3x the longest cross-manifold route
MAX_EPISODE_STEPS = 600


def register_envs() -> None:
    # No TimeLimit wrapper: ServoEnv keeps its own clock (max_steps), which also names the
    # reason ("time limit"); a second clock would cut a longer max_steps short.
    register_per_world(
        {"topomap/HallwayServo-v0": "hallway", "topomap/LawnServo-v0": "lawn"},
        "servo.task.env:ServoEnv",
        None,
    )

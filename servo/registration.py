"""Gymnasium registration of the servo tasks with string entry points."""

from __future__ import annotations

from sim.registration import register_per_world

MAX_EPISODE_STEPS = 600  # 60 s of simulated time: ~3x the longest cross-manifold route


def register_envs() -> None:
    register_per_world(
        {"topomap/HallwayServo-v0": "hallway", "topomap/LawnServo-v0": "lawn"},
        "servo.env:ServoEnv",
        MAX_EPISODE_STEPS,
    )

"""Worlds of the testbed, built in code: a branching indoor hallway and an outdoor lawn.

``build_world(name, rng=None)`` (`scenes.registry`) returns a [`World`][scenes.world.World]
with the MJCF, textures and the ground truth (manifold regions, free space, teleop routes).
Nothing here imports MuJoCo: compiling and simulating is ``sim``'s job.
"""

from scenes.appearance import RANDOMIZATION
from scenes.names import MANIFOLD_IDS, MANIFOLDS, NO_MANIFOLD, WORLDS
from scenes.registry import build_world
from scenes.world import World

__all__ = [
    "MANIFOLDS",
    "MANIFOLD_IDS",
    "NO_MANIFOLD",
    "RANDOMIZATION",
    "WORLDS",
    "World",
    "build_world",
]

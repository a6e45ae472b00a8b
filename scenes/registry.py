"""The worlds by name: [`build_world`][scenes.registry.build_world] finds the builder in `BUILDERS`.

Kept apart from `scenes.world` so that the builders can import ``World`` without an
import cycle: ``registry`` -> ``hallway``, ``lawn`` -> ``world``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from scenes import names
from scenes.appearance import Appearance, draw_appearance
from scenes.families import build_family_world, parse_world_name
from scenes.hallway import build_hallway
from scenes.lawn import build_lawn
from scenes.world import World

__all__ = ["BUILDERS", "build_world"]

# world name -> builder of the world from one appearance draw
BUILDERS: dict[str, Callable[[Appearance], World]] = {
    names.HALLWAY: build_hallway,
    names.LAWN: build_lawn,
}


def build_world(
    name: str, rng: np.random.Generator | None = None, appearance: str = "default"
) -> World:
    """Build a world by name.

    Parameters
    ----------
    name : str
        ``"hallway"`` or ``"lawn"`` (the canonical worlds), or ``FAMILY:SEED`` for a
        generated world of that family (``"hallway:17"``, ``"lawn:3"``; seeds 0 to
        `MAX_SEED`, seed 0 being the canonical world); see
        `scenes.families`.
    rng : numpy.random.Generator, optional
        Without one, the canonical world (fixed textures, default lights and clutter). With one,
        a domain-randomised variant (textures, colours, lighting, clutter placement), the same
        for the same generator state.
    appearance : {"default", "hard"}, default "default"
        ``"hard"``: every branch shares the main manifold's wall, floor and light materials
        (see `APPEARANCE_MODES`); the geometry is that of the default
        world.

    Returns
    -------
    World
        The world, ready to simulate, with its ground truth.
    """
    world = parse_world_name(name)
    if not world.canonical:
        return build_family_world(world, rng, appearance)
    return BUILDERS[world.family](draw_appearance(rng, appearance))

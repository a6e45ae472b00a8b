"""The worlds by name: :func:`build_world` looks the builder up in :data:`BUILDERS`.

Kept apart from :mod:`scenes.world` so that the builders can import ``World`` without an
import cycle: ``registry`` -> ``hallway``, ``lawn`` -> ``world``.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from scenes import names
from scenes.appearance import Appearance, draw_appearance
from scenes.hallway import build_hallway
from scenes.lawn import build_lawn
from scenes.world import World

__all__ = ["BUILDERS", "build_world"]

# world name -> builder of the world from one appearance draw
BUILDERS: dict[str, Callable[[Appearance], World]] = {
    names.HALLWAY: build_hallway,
    names.LAWN: build_lawn,
}


def build_world(name: str, rng: np.random.Generator | None = None) -> World:
    """Build a world by name.

    Parameters
    ----------
    name : {"hallway", "lawn"}
    rng : numpy.random.Generator, optional
        Without one, the canonical world (fixed textures, default lights and clutter). With one,
        a domain-randomised variant (textures, colours, lighting, clutter placement), the same
        for the same generator state.
    """
    if name not in names.WORLDS:
        raise ValueError(f"world must be one of {names.WORLDS}, got {name!r}")
    return BUILDERS[name](draw_appearance(rng))

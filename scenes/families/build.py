"""A generated world from its name: the layout, the looks and the scene, from one seed."""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache

import numpy as np

from scenes.appearance import draw_appearance
from scenes.families.draw import draw_layout
from scenes.families.indoor import build_indoor
from scenes.families.layout import Layout
from scenes.families.naming import FAMILIES, WorldName, parse_world_name
from scenes.families.outdoor import build_outdoor
from scenes.regions import ManifoldMap
from scenes.robot import add_robot
from scenes.world import World

__all__ = ["WORLD_KEY", "build_family_world", "family_layout"]

WORLD_KEY = 53_000  # the first word of every generated world's seed sequence
_BUILDERS = {"hallway": build_indoor, "lawn": build_outdoor}


def _streams(name: WorldName) -> list[np.random.Generator]:
    """Return the world's own generators: layout, looks and furnishing, textures."""
    root = np.random.default_rng([WORLD_KEY, FAMILIES.index(name.family), name.seed])
    return root.spawn(3)


@lru_cache(maxsize=64)
def family_layout(name) -> Layout:
    """Return the floor plan of a generated world (no scene, no textures: milliseconds).

    Parameters
    ----------
    name : str or WorldName
        ``FAMILY:SEED`` with a seed >= 1 (seed 0 is the canonical world, built by hand).

    Returns
    -------
    Layout
        The floor plan (cached).
    """
    name = parse_world_name(name)
    if name.canonical:
        raise ValueError(f"{name} is a canonical world: it has no generated layout")
    return draw_layout(name.family, _streams(name)[0], str(name))


def build_family_world(
    name, rng: np.random.Generator | None = None, appearance: str = "default"
) -> World:
    """Build the generated world ``name`` (``FAMILY:SEED``, seed >= 1).

    Parameters
    ----------
    name : str or WorldName
        ``FAMILY:SEED`` with a seed >= 1.
    rng : numpy.random.Generator, optional
        Domain randomisation on top of the world (lights, colours, clutter), as for the
        canonical worlds; the layout, looks and furnishing come from the name alone.
    appearance : {"default", "hard"}, default "default"
        ``"hard"``: every manifold wears the main manifold's materials and light.

    Returns
    -------
    World
        The world with its ground truth.
    """
    name = parse_world_name(name)
    layout = family_layout(name)
    _, look_rng, texture_rng = _streams(name)
    app = draw_appearance(rng, appearance)
    if rng is None:  # every world its own textures; the canonical worlds keep theirs
        app = replace(app, texture_rng=texture_rng)
    scene, bounds = _BUILDERS[name.family](str(name), layout, app, look_rng)
    add_robot(scene)
    parents = {
        s.name: None if s.parent is None else layout.stretches[s.parent].name
        for s in layout.stretches
    }
    return World.from_scene(
        str(name),
        scene,
        app,
        ManifoldMap(tuple(layout.regions())),
        bounds,
        layout.routes(),
        parents=parents,
    )

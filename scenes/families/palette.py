"""Each family's palette: the looks a generated world's manifolds wear, and their draw.

A look is a set of materials and a kind of furnishing. Every manifold of a generated world
draws one look, different from its parent's and its siblings' while the palette lasts, and
jitters its base colours, so that worlds of one family share a style but no two are alike. In
the ``"hard"`` appearance mode every manifold wears the main manifold's look (only the layout
and the furnishing tell them apart), as in the canonical worlds.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.families.layout import Layout

__all__ = ["INDOOR_LOOKS", "OUTDOOR_LOOKS", "Look", "draw_looks"]


@dataclass(frozen=True)
class Look:
    """One manifold's style.

    Parameters
    ----------
    name : str
        The look's name.
    wall : (str, tuple)
        A texture of `scenes.textures` and its colours (walls, or fences outdoors).
    floor : (str, tuple)
        The floor's (the ground's outdoors) texture and colours.
    light : tuple of float
        The colour of its light (indoors).
    furnishing : str
        What stands along its sides (`scenes.families.indoor`,
        `scenes.families.outdoor`).
    """

    name: str
    wall: tuple
    floor: tuple
    light: tuple[float, float, float]
    furnishing: str


# the canonical hallway's four looks first, then four more of the same kind
INDOOR_LOOKS = (
    Look(
        "plaster",
        ("painted", ((0.86, 0.80, 0.66),)),
        ("speckled", ((0.35, 0.42, 0.55),)),
        (1.0, 0.98, 0.92),
        "offices",
    ),
    Look(
        "brick",
        ("bricks", ((0.62, 0.24, 0.16),)),
        ("planks", ((0.62, 0.42, 0.24),)),
        (1.0, 0.8, 0.55),
        "library",
    ),
    Look(
        "gallery",
        ("stripes", ((0.45, 0.62, 0.82), (0.15, 0.3, 0.6))),
        ("tiles", ((0.92, 0.92, 0.9), (0.12, 0.12, 0.14))),
        (0.7, 0.85, 1.0),
        "gallery",
    ),
    Look(
        "service",
        ("speckled", ((0.58, 0.58, 0.56),)),
        ("speckled", ((0.22, 0.42, 0.3),)),
        (0.6, 0.65, 0.6),
        "service",
    ),
    Look(
        "mint",
        ("painted", ((0.55, 0.78, 0.62),)),
        ("tiles", ((0.55, 0.55, 0.58), (0.4, 0.4, 0.42))),
        (0.95, 1.0, 0.95),
        "offices",
    ),
    Look(
        "ochre",
        ("stripes", ((0.85, 0.68, 0.3), (0.55, 0.35, 0.15))),
        ("speckled", ((0.5, 0.2, 0.18),)),
        (1.0, 0.88, 0.7),
        "gallery",
    ),
    Look(
        "clinic",
        ("tiles", ((0.93, 0.95, 0.97), (0.7, 0.75, 0.8))),
        ("planks", ((0.3, 0.2, 0.14),)),
        (0.85, 0.92, 1.0),
        "service",
    ),
    Look(
        "violet",
        ("painted", ((0.55, 0.45, 0.68),)),
        ("speckled", ((0.75, 0.68, 0.55),)),
        (1.0, 0.85, 0.95),
        "library",
    ),
)

# the canonical lawn's surfaces and boundaries, recombined
OUTDOOR_LOOKS = (
    Look(
        "lawn",
        ("planks", ((0.55, 0.4, 0.25),)),
        ("grass", ((0.25, 0.5, 0.15),)),
        (0.85, 0.82, 0.75),
        "garden",
    ),
    Look(
        "driveway",
        ("planks", ((0.55, 0.4, 0.25),)),
        ("speckled", ((0.22, 0.22, 0.24),)),
        (0.85, 0.82, 0.75),
        "street",
    ),
    Look(
        "orchard",
        ("planks", ((0.45, 0.32, 0.2),)),
        ("gravel", ((0.62, 0.56, 0.46),)),
        (0.85, 0.82, 0.75),
        "orchard",
    ),
    Look(
        "sidewalk",
        ("bricks", ((0.6, 0.58, 0.52),)),
        ("tiles", ((0.72, 0.72, 0.7), (0.66, 0.66, 0.63))),
        (0.85, 0.82, 0.75),
        "street",
    ),
    Look(
        "meadow",
        ("bricks", ((0.55, 0.5, 0.45),)),
        ("grass", ((0.42, 0.55, 0.2),)),
        (0.85, 0.82, 0.75),
        "orchard",
    ),
    Look(
        "yard",
        ("planks", ((0.35, 0.3, 0.28),)),
        ("speckled", ((0.55, 0.42, 0.3),)),
        (0.85, 0.82, 0.75),
        "garden",
    ),
)


def draw_looks(layout: Layout, palette: tuple[Look, ...], rng: np.random.Generator) -> list[Look]:
    """Draw one look per stretch of ``layout``.

    The main stretch's is drawn first; each other differs from its parent's and siblings'
    where the palette allows.

    Parameters
    ----------
    layout : Layout
        The floor plan.
    palette : tuple of Look
        The looks to draw from.
    rng : numpy.random.Generator
        The generator of the draw.

    Returns
    -------
    list of Look
        One look per stretch, in the order of ``layout.stretches``.
    """
    first = int(rng.integers(len(palette)))
    looks = [first]
    for i, s in enumerate(layout.stretches[1:], start=1):
        taken = {looks[s.parent]} | {looks[k] for k in layout.children[s.parent] if k < i}
        free = [k for k in range(len(palette)) if k not in taken] or list(range(len(palette)))
        looks.append(int(rng.choice(free)))
    return [palette[k] for k in looks]

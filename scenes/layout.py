"""Compact layout pieces shared by the world builders: rectangles of floor and their walls."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from scenes.mjcf import SceneBuilder

FLOOR_THICKNESS = 0.05  # m; a thin box renders ~2x faster than a huge subdivided plane


@dataclass(frozen=True)
class Rect:
    """An axis-aligned rectangle of floor, metres.

    Parameters
    ----------
    x0, x1 : float
        Its west and east edges, m.
    y0, y1 : float
        Its south and north edges, m.
    """

    x0: float
    x1: float
    y0: float
    y1: float

    @property
    def center(self) -> tuple[float, float]:
        """(x, y) of the rectangle's centre, m."""
        return ((self.x0 + self.x1) / 2.0, (self.y0 + self.y1) / 2.0)

    @property
    def half(self) -> tuple[float, float]:
        """Half the rectangle's width and depth, m."""
        return ((self.x1 - self.x0) / 2.0, (self.y1 - self.y0) / 2.0)

    def corners(self) -> np.ndarray:
        """Return the corners, counter-clockwise from (x0, y0).

        Returns
        -------
        ndarray of shape (4, 2)
            The corners, m.
        """
        return np.array(
            [[self.x0, self.y0], [self.x1, self.y0], [self.x1, self.y1], [self.x0, self.y1]]
        )


def add_floor(scene: SceneBuilder, name: str, rect: Rect, material: str, z: float = 0.0) -> None:
    """Add a visual-only floor slab whose top face is at height ``z``.

    Parameters
    ----------
    scene : SceneBuilder
        The scene to add it to.
    name : str
        The slab geom's name.
    rect : Rect
        The floor's rectangle.
    material : str
        The slab's material.
    z : float, default 0.0
        Height of the top face, m.
    """
    cx, cy = rect.center
    hx, hy = rect.half
    scene.box(
        name,
        (cx, cy, z - FLOOR_THICKNESS),
        (hx, hy, FLOOR_THICKNESS),
        material,
        collide=False,
        group=1,
    )


def add_walls(
    scene: SceneBuilder,
    prefix: str,
    rect: Rect,
    sides: str,
    material: str,
    height: float,
    thickness: float,
) -> None:
    """Walls along the chosen sides of ``rect`` ("n", "s", "e", "w"), just outside the floor.

    A wall spans exactly its side: extended past a corner it would poke into a neighbouring
    corridor that opens there (the junction); where two walls of one rectangle meet, they meet
    edge to edge, which leaves no gap visible from inside.

    Parameters
    ----------
    scene : SceneBuilder
        The scene to add them to.
    prefix : str
        Start of the walls' names (``<prefix>_wall_<side>``).
    rect : Rect
        The floor's rectangle.
    sides : str
        The sides to wall, letters of ``"nsew"``.
    material : str
        The walls' material.
    height, thickness : float
        The walls' height and thickness, m.
    """
    t = thickness / 2.0
    hz = height / 2.0
    hx, hy = rect.half
    cx, cy = rect.center
    walls = {
        "n": ((cx, rect.y1 + t, hz), (hx, t, hz)),
        "s": ((cx, rect.y0 - t, hz), (hx, t, hz)),
        "e": ((rect.x1 + t, cy, hz), (t, hy, hz)),
        "w": ((rect.x0 - t, cy, hz), (t, hy, hz)),
    }
    for side in sides:
        if side not in walls:
            raise ValueError(f"sides must be letters of 'nsew', got {sides!r}")
        center, half = walls[side]
        scene.box(f"{prefix}_wall_{side}", center, half, material)


def wall_anchor(rect: Rect, side: str, along: float, offset: float) -> tuple[float, float, float]:
    """Return a point on the inside face of a wall of ``rect``, facing into the room.

    Parameters
    ----------
    rect : Rect
        The floor's rectangle.
    side : {"n", "s", "e", "w"}
        The wall.
    along : float
        Distance from the wall's start (west or south end), m.
    offset : float
        Distance into the room, m.

    Returns
    -------
    tuple of float
        (x, y, yaw facing into the room).
    """
    if side == "n":
        return rect.x0 + along, rect.y1 - offset, -np.pi / 2
    if side == "s":
        return rect.x0 + along, rect.y0 + offset, np.pi / 2
    if side == "e":
        return rect.x1 - offset, rect.y0 + along, np.pi
    if side == "w":
        return rect.x0 + offset, rect.y0 + along, 0.0
    raise ValueError(f"side must be one of 'nsew', got {side!r}")

"""Things placed against walls or on the floor: doors, posters, shelves, plants, trees.

Shared by both world builders, so that each layout is a readable list of placements.
"""

from __future__ import annotations

import numpy as np

from scenes import meshes, names
from scenes.layout import Rect, wall_anchor
from scenes.mjcf import SceneBuilder


def wall_box(
    scene: SceneBuilder,
    name: str,
    rect: Rect,
    side: str,
    along: float,
    width: float,
    depth: float,
    height: float,
    material: str,
    z0: float = 0.0,
    collide: bool = True,
) -> None:
    """Add a box standing against the inside of a wall: a door, a poster, a shelf, a locker.

    Flat items (posters, doors) are visual only; furniture collides.

    Parameters
    ----------
    scene : SceneBuilder
        The scene to add it to.
    name : str
        The box geom's name.
    rect : Rect
        The floor's rectangle.
    side : {"n", "s", "e", "w"}
        The wall it stands against.
    along : float
        The box centre's distance from the wall's start (west or south end), m.
    width : float
        Its extent along the wall, m.
    depth : float
        Its extent into the room, m.
    height : float
        Its height, m.
    material : str
        Its material.
    z0 : float, default 0.0
        Height of its bottom, m.
    collide : bool, default True
        Whether it collides (else visual only).
    """
    x, y, yaw = wall_anchor(rect, side, along, depth / 2.0)
    yaw_box = 0.0 if side in "ns" else np.pi / 2
    del yaw  # the box is symmetric: only the wall's direction matters
    scene.box(
        name,
        (x, y, z0 + height / 2.0),
        (width / 2.0, depth / 2.0, height / 2.0),
        material,
        yaw=yaw_box,
        collide=collide,
        group=names.GROUP_SOLID if collide else names.GROUP_DECOR,
    )


def potted_plant(
    scene: SceneBuilder,
    name: str,
    x: float,
    y: float,
    rng: np.random.Generator,
    pot_material: str,
    leaf_material: str,
) -> None:
    """Add a pot (collides) with a lumpy bush on top (visual).

    Parameters
    ----------
    scene : SceneBuilder
        The scene to add it to.
    name : str
        Start of its geoms' and mesh's names.
    x, y : float
        Where it stands, m.
    rng : numpy.random.Generator
        The generator of the bush's lumps.
    pot_material, leaf_material : str
        The materials of the pot and the bush.
    """
    scene.cylinder(f"{name}_pot", (x, y, 0.22), 0.22, 0.22, pot_material)
    scene.mesh(f"{name}_leaves_mesh", meshes.bush(rng, 0.35))
    scene.mesh_geom(f"{name}_leaves", f"{name}_leaves_mesh", (x, y, 0.35), leaf_material)


def tree(
    scene: SceneBuilder,
    name: str,
    x: float,
    y: float,
    rng: np.random.Generator,
    bark_material: str,
    leaf_material: str,
    height: float | None = None,
) -> None:
    """Add a tree: a trunk (collision cylinder + tapered visual mesh) and a lumpy crown.

    Parameters
    ----------
    scene : SceneBuilder
        The scene to add it to.
    name : str
        Start of its geoms' and meshes' names.
    x, y : float
        Where it stands, m.
    rng : numpy.random.Generator
        The generator of its size and shape.
    bark_material, leaf_material : str
        The materials of the trunk and the crown.
    height : float or None, default None
        Its height, m; None: drawn from 3.5 to 6.
    """
    height = float(rng.uniform(3.5, 6.0)) if height is None else height
    radius = float(rng.uniform(0.15, 0.28))
    scene.mesh(f"{name}_trunk_mesh", meshes.trunk(rng, radius, height * 0.75))
    crown = float(rng.uniform(1.2, 2.0))
    scene.mesh(f"{name}_crown_mesh", meshes.canopy(rng, crown))
    place_tree(scene, name, x, y, (height, radius, crown), name, bark_material, leaf_material)


def place_tree(
    scene: SceneBuilder,
    name: str,
    x: float,
    y: float,
    shape: tuple[float, float, float],
    meshes_of: str,
    bark_material: str,
    leaf_material: str,
) -> None:
    """Add the geoms of a tree of ``shape`` at ``(x, y)``.

    They are its collision cylinder and the visual meshes ``{meshes_of}_trunk_mesh`` and
    ``{meshes_of}_crown_mesh``, made beforehand (one shape may be planted many times).

    Parameters
    ----------
    scene : SceneBuilder
        The scene to add them to.
    name : str
        Start of the geoms' names.
    x, y : float
        Where the tree stands, m.
    shape : tuple of float
        (height, trunk radius, crown radius), m.
    meshes_of : str
        Start of the names of the trunk and crown meshes.
    bark_material, leaf_material : str
        The materials of the trunk and the crown.
    """
    height, radius, crown = shape
    scene.cylinder(
        f"{name}_trunk_collider",
        (x, y, 1.0),
        radius,
        1.0,
        None,
        group=names.GROUP_COLLIDER,
        rgba=(0.4, 0.3, 0.2, 1),
    )
    scene.mesh_geom(f"{name}_trunk", f"{meshes_of}_trunk_mesh", (x, y, 0.0), bark_material)
    scene.mesh_geom(
        f"{name}_crown",
        f"{meshes_of}_crown_mesh",
        (x, y, height * 0.75 + 0.4 * crown),
        leaf_material,
    )


def sky_and_street_materials(scene: SceneBuilder, colour) -> None:
    """Add the outdoor worlds' sky box and the materials of cars, their windows and mailboxes.

    Parameters
    ----------
    scene : SceneBuilder
        The scene to add them to.
    colour : callable
        The appearance's colour jitter, ``Appearance.colour``.
    """
    scene.builtin_texture(
        "tex_sky",
        type="skybox",
        builtin="gradient",
        rgb1="0.55 0.72 0.92",
        rgb2="0.95 0.97 1.0",
        width="256",
        height="256",
    )
    scene.material("mat_car", rgba=colour((0.1, 0.2, 0.55)) + (1,), specular=0.8, shininess=0.8)
    scene.material("mat_glass", rgba=(0.1, 0.12, 0.15, 1), specular=0.9, shininess=0.9)
    scene.material("mat_mailbox", rgba=colour((0.15, 0.15, 0.15)) + (1,))


def hedge(
    scene: SceneBuilder,
    name: str,
    x0: float,
    y0: float,
    x1: float,
    y1: float,
    rng: np.random.Generator,
    leaf_material: str,
    height: float = 1.4,
    thickness: float = 0.8,
) -> None:
    """Add a hedge from (x0, y0) to (x1, y1): lumpy bushes (visual) over a box collider.

    Parameters
    ----------
    scene : SceneBuilder
        The scene to add it to.
    name : str
        Start of its geoms' and meshes' names.
    x0, y0, x1, y1 : float
        Its ends, m.
    rng : numpy.random.Generator
        The generator of the bushes' lumps.
    leaf_material : str
        The bushes' material.
    height : float, default 1.4
        The collider's height, m.
    thickness : float, default 0.8
        The collider's thickness, m.
    """
    length = float(np.hypot(x1 - x0, y1 - y0))
    yaw = float(np.arctan2(y1 - y0, x1 - x0))
    scene.box(
        f"{name}_collider",
        ((x0 + x1) / 2, (y0 + y1) / 2, height / 2),
        (length / 2, thickness / 2, height / 2),
        None,
        yaw=yaw,
        group=names.GROUP_COLLIDER,
    )
    n = max(2, int(length / 1.2))
    # A few bush shapes reused along the hedge keep the model small.
    shapes = [scene.mesh(f"{name}_bush_mesh{k}", meshes.bush(rng, 0.75)) for k in range(3)]
    for k in range(n):
        t = (k + 0.5) / n
        scene.mesh_geom(
            f"{name}_bush{k}",
            shapes[k % 3],
            (x0 + t * (x1 - x0), y0 + t * (y1 - y0), -0.1),
            leaf_material,
        )

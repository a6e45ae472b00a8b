"""Building a generated layout into a scene: floors, walls, placements and materials.

Floors and walls at any angle, things placed along a stretch's sides, and the per-look
materials. Shared by the indoor and outdoor builders.
"""

from __future__ import annotations

import numpy as np

from scenes import meshes, names, textures
from scenes.appearance import Appearance
from scenes.families.layout import Layout
from scenes.families.palette import Look
from scenes.layout import FLOOR_THICKNESS
from scenes.mjcf import SceneBuilder

__all__ = ["add_floors", "add_walls", "along", "look_materials"]


def along(
    layout: Layout, i: int, s: float, side: float, inset: float
) -> tuple[float, float, float]:
    """Return a point of stretch ``i`` and the stretch's heading.

    Parameters
    ----------
    layout : Layout
        The floor plan.
    i : int
        Index of the stretch.
    s : float
        Distance along its centre line from its start, m.
    side : float
        1: its left side, -1: its right side (0: the centre line).
    inset : float
        Distance in from the wall, m.

    Returns
    -------
    tuple of float
        ``(x, y, heading)``.
    """
    st = layout.stretches[i]
    u = np.array([np.cos(st.heading), np.sin(st.heading)])
    n = np.array([-u[1], u[0]])
    p = np.asarray(st.start) + s * u + side * (layout.half_width - inset) * n
    return float(p[0]), float(p[1]), float(st.heading)


def _texture(kind: str, rng: np.random.Generator, colours: list) -> np.ndarray:
    if kind == "stripes":
        return textures.stripes(rng, colours[0], colours[1])
    if kind == "tiles":
        return textures.tiles(rng, colours[0], colours[1])
    if kind == "gravel":
        return textures.speckled(rng, colours[0], contrast=0.45)
    if kind == "speckled":
        return textures.speckled(rng, colours[0], contrast=0.25)
    return getattr(textures, kind)(rng, colours[0])


def look_materials(
    scene: SceneBuilder,
    looks: list[Look],
    app: Appearance,
    rng: np.random.Generator,
    floor_repeat: float = 1.0,
) -> list[tuple[str, str]]:
    """Make the wall and floor materials of every stretch.

    One texture pair per distinct look, its colours jittered by ``rng`` (this world's) and by
    the appearance draw. In the hard mode every stretch gets the main stretch's pair.

    Parameters
    ----------
    scene : SceneBuilder
        The scene to add the textures and materials to.
    looks : list of Look
        Each stretch's look.
    app : Appearance
        The appearance draw (colour jitter, texture generator, mode).
    rng : numpy.random.Generator
        This world's generator of the colour jitter.
    floor_repeat : float, default 1.0
        The floor textures' repeats per metre.

    Returns
    -------
    list of (str, str)
        ``[(wall, floor), ...]``: the material names, one pair per stretch.
    """
    made: dict[str, tuple[str, str]] = {}
    # one jitter per look and part, drawn whichever looks are made, so that the hard mode
    # leaves the generator where the default mode does (the furnishing draws from it next)
    jitters = rng.uniform(-0.06, 0.06, (len(looks), 2, 3))
    for k, look in enumerate(looks if not app.shared_materials else looks[:1]):
        if look.name in made:
            continue
        pair = []
        for part, (kind, colours), jitter in zip(
            ("wall", "floor"), (look.wall, look.floor), jitters[k], strict=True
        ):
            cols = [app.colour(np.clip(np.asarray(c) + jitter, 0, 1)) for c in colours]
            name = f"{look.name}_{part}"
            scene.texture(f"tex_{name}", _texture(kind, app.texture_rng, cols))
            repeat = (floor_repeat, floor_repeat) if part == "floor" else (1.0, 1.0)
            scene.material(f"mat_{name}", f"tex_{name}", texrepeat=repeat, texuniform=True)
            if part == "floor":  # the hubs are meshes with their own texture coordinates,
                # which MuJoCo's uniform mapping would smear into streaks
                scene.material(f"mat_{name}_hub", f"tex_{name}", texrepeat=repeat, texuniform=False)
            pair.append(f"mat_{name}")
        made[look.name] = (pair[0], pair[1])
    if app.shared_materials:
        return [made[looks[0].name]] * len(looks)
    return [made[look.name] for look in looks]


def add_floors(
    scene: SceneBuilder, layout: Layout, floor_materials: list[str], z: float = 0.0
) -> None:
    """Add a floor slab under every stretch's rectangle and every junction's hub.

    A hub wears the floor of the stretch that arrives at it (as the canonical junctions do).

    Parameters
    ----------
    scene : SceneBuilder
        The scene to add them to.
    layout : Layout
        The floor plan.
    floor_materials : list of str
        Each stretch's floor material.
    z : float, default 0.0
        Height of the floor's top face, m.
    """
    for i in range(len(layout.stretches)):
        s0, s1 = layout.extent(i)
        x, y, heading = along(layout, i, (s0 + s1) / 2, 0.0, 0.0)
        scene.box(
            f"floor{i}",
            (x, y, z - FLOOR_THICKNESS),
            ((s1 - s0) / 2, layout.half_width, FLOOR_THICKNESS),
            floor_materials[i],
            yaw=heading,
            collide=False,
            group=names.GROUP_DECOR,
        )
    for owner, junction in layout.junctions.items():
        polygon = junction.polygon(layout.half_width)
        slab = meshes.floor_slab(polygon, junction.centre, 2 * FLOOR_THICKNESS)
        scene.mesh(f"hub{owner}_mesh", slab)
        material = f"{floor_materials[owner]}_hub"  # see look_materials
        scene.mesh_geom(f"hub{owner}_floor", f"hub{owner}_mesh", (0, 0, z), material)


def add_walls(
    scene: SceneBuilder,
    layout: Layout,
    wall_materials: list[str],
    height: float,
    thickness: float,
    group: int = names.GROUP_SOLID,
    prefix: str = "wall",
) -> None:
    """Add a box along every wall of ``layout``, just outside the floor.

    Each is in its stretch's material; walls meet at outer corners and stop short of sharp
    inner ones (`Wall`).

    Parameters
    ----------
    scene : SceneBuilder
        The scene to add them to.
    layout : Layout
        The floor plan.
    wall_materials : list of str
        Each stretch's wall material.
    height, thickness : float
        The walls' height and thickness, m.
    group : int, default names.GROUP_SOLID
        The walls' geom group.
    prefix : str, default "wall"
        Start of the walls' names.
    """
    for k, wall in enumerate(layout.walls()):
        centre, half_length, yaw = wall.box(thickness)
        scene.box(
            f"{prefix}{k}",
            (centre[0], centre[1], height / 2),
            (half_length, thickness / 2, height / 2),
            wall_materials[wall.stretch],
            yaw=yaw,
            group=group,
        )

"""The indoor family (``hallway:SEED``): corridors joined by bends, T, Y and X junctions.

Each corridor wears a look of `INDOOR_LOOKS` (walls, floor,
light colour) and its furnishing: offices (doors and posters), a library (shelves and a
bench), a gallery (posters and potted plants) or a service corridor (lockers and fire
extinguishers). Closed ends carry a door, the main corridor's a window. Walls reach the
ceiling, as in the canonical hallway.
"""

from __future__ import annotations

import numpy as np

from scenes import names, textures
from scenes.appearance import Appearance
from scenes.families.furnish import add_floors, add_walls, along, look_materials
from scenes.families.layout import Layout
from scenes.families.palette import INDOOR_LOOKS, draw_looks
from scenes.furnish import potted_plant
from scenes.mjcf import SceneBuilder

__all__ = ["MAX_LIGHTS", "build_indoor"]

WALL_HEIGHT = 2.6
WALL_THICKNESS = 0.15
DOOR_WIDTH, DOOR_HEIGHT = 0.9, 2.05
# The renderer lights a scene with at most 8 lights, the headlight among them: the first 7
# corridors (depth first) get a ceiling light, the others the headlight's ambient alone.
MAX_LIGHTS = 7


def _box_along(
    scene, name, layout, i, s, side, width, depth, height, material, z0=0.0, collide=True
):
    """Add a box against a side wall of stretch ``i``: a door, a poster, a shelf, a locker."""
    x, y, heading = along(layout, i, s, side, depth / 2)
    scene.box(
        name,
        (x, y, z0 + height / 2),
        (width / 2, depth / 2, height / 2),
        material,
        yaw=heading,
        collide=collide,
        group=names.GROUP_SOLID if collide else names.GROUP_DECOR,
    )


def _furnish(
    scene: SceneBuilder,
    layout: Layout,
    i: int,
    kind: str,
    app: Appearance,
    rng: np.random.Generator,
) -> None:
    s0, s1 = layout.extent(i)
    shift = app.shift("clutter_shift")
    marks = np.arange(s0 + 2.0, s1 - 1.5, rng.uniform(2.4, 3.4)) + shift
    marks = marks[(marks > s0 + 1.2) & (marks < s1 - 1.2)]
    side0 = float(rng.choice([-1.0, 1.0]))
    for k, s in enumerate(marks):
        side = side0 if k % 2 == 0 else -side0
        tag = f"s{i}_{k}"
        if kind == "offices":
            if k % 2 == 0:
                _box_along(
                    scene,
                    f"{tag}_door",
                    layout,
                    i,
                    s,
                    side,
                    DOOR_WIDTH,
                    0.04,
                    DOOR_HEIGHT,
                    "mat_door",
                    collide=False,
                )
            else:
                _box_along(
                    scene,
                    f"{tag}_poster",
                    layout,
                    i,
                    s,
                    side,
                    0.7,
                    0.02,
                    0.9,
                    f"mat_poster{k % 4}",
                    z0=1.2,
                    collide=False,
                )
        elif kind == "library":
            if k % 3 == 2:
                _box_along(
                    scene, f"{tag}_bench", layout, i, s, -side0, 1.6, 0.45, 0.45, "mat_bench"
                )
            else:
                _box_along(scene, f"{tag}_shelf", layout, i, s, side0, 1.8, 0.4, 2.0, "mat_shelf")
        elif kind == "gallery":
            _box_along(
                scene,
                f"{tag}_poster",
                layout,
                i,
                s,
                side,
                1.0,
                0.02,
                1.2,
                f"mat_poster{k % 4}",
                z0=1.0,
                collide=False,
            )
            if k % 2 == 1:
                x, y, _ = along(layout, i, s, -side, 0.35)
                potted_plant(scene, f"{tag}_plant", x, y, app.texture_rng, "mat_pot", "mat_leaves")
        else:  # service
            if k % 2 == 0:
                for m in range(int(rng.integers(1, 4))):
                    _box_along(
                        scene,
                        f"{tag}_locker{m}",
                        layout,
                        i,
                        s + 0.6 * m,
                        side0,
                        0.55,
                        0.45,
                        1.8,
                        "mat_locker",
                    )
            else:
                x, y, _ = along(layout, i, s, -side0, 0.12)
                scene.cylinder(f"{tag}_extinguisher", (x, y, 0.3), 0.09, 0.3, "mat_red")


def _shared_materials(scene: SceneBuilder, app: Appearance) -> None:
    rng, c = app.texture_rng, app.colour
    scene.texture("tex_ceiling", textures.ceiling_tiles(rng))
    scene.material("mat_ceiling", "tex_ceiling", texrepeat=(0.5, 0.5))
    scene.material("mat_ceiling_hub", "tex_ceiling", texrepeat=(0.5, 0.5), texuniform=False)
    scene.texture("tex_door", textures.panelled_door(rng))
    scene.material("mat_door", "tex_door", texuniform=False)
    scene.texture("tex_window", textures.window_facade(rng, c((0.9, 0.88, 0.82))))
    scene.material("mat_window", "tex_window", texuniform=False)
    for k in range(4):
        scene.texture(f"tex_poster{k}", textures.poster(rng))
        scene.material(f"mat_poster{k}", f"tex_poster{k}", texuniform=False)
    scene.material("mat_shelf", rgba=c((0.35, 0.22, 0.12)) + (1,))
    scene.material("mat_locker", rgba=c((0.55, 0.58, 0.62)) + (1,), specular=0.4)
    scene.material("mat_pot", rgba=c((0.55, 0.3, 0.2)) + (1,))
    scene.material("mat_leaves", rgba=c((0.2, 0.5, 0.2)) + (1,))
    scene.material("mat_red", rgba=(0.8, 0.05, 0.05, 1), specular=0.5, shininess=0.6)
    scene.material("mat_bench", rgba=c((0.3, 0.2, 0.12)) + (1,))


def build_indoor(name: str, layout: Layout, app: Appearance, rng: np.random.Generator):
    """Build the scene of an indoor world: ``(scene, bounds)`` for [`World`][scenes.world.World].

    ``rng`` draws the looks and the furnishing (part of the world, like its layout); ``app``
    the domain randomisation on top (lights, colours, clutter shift).

    Parameters
    ----------
    name : str
        The world's name (the model's name).
    layout : Layout
        The floor plan.
    app : Appearance
        The appearance draw.
    rng : numpy.random.Generator
        This world's generator of the looks and furnishing.

    Returns
    -------
    scene : SceneBuilder
        The scene, without the robot.
    bounds : tuple of float
        ``(xmin, xmax, ymin, ymax)`` of the floor plan, m.
    """
    scene = SceneBuilder(name)
    x0, x1, y0, y1 = layout.bounds()
    extent = max(x1 - x0, y1 - y0)
    centre = ((x0 + x1) / 2, (y0 + y1) / 2, 1.0)
    scene.set_visual(extent, centre, headlight_ambient=0.25, headlight_diffuse=0.15)
    looks = draw_looks(layout, INDOOR_LOOKS, rng)
    _shared_materials(scene, app)
    pairs = look_materials(scene, looks, app, rng)
    add_floors(scene, layout, [f for _, f in pairs])
    add_floors_ceiling(scene, layout)
    add_walls(scene, layout, [w for w, _ in pairs], WALL_HEIGHT + 0.1, WALL_THICKNESS)
    for i, look in enumerate(looks):
        _furnish(scene, layout, i, look.furnishing, app, rng)
    _end_decals(scene, layout)
    main_light = looks[0].light
    for i, look in enumerate(looks[:MAX_LIGHTS]):
        s0, s1 = layout.extent(i)
        x, y, _ = along(layout, i, (s0 + s1) / 2 + app.shift("light_shift"), 0.0, 0.0)
        colour = main_light if app.shared_materials else look.light
        scene.light(
            f"light{i}",
            (x, y, WALL_HEIGHT - 0.05),
            diffuse=app.light(colour),
            attenuation=(0.4, 0.0, 0.04),
            cutoff=85.0,
        )
    return scene, layout.bounds()


def add_floors_ceiling(scene: SceneBuilder, layout: Layout) -> None:
    """Add the ceiling: the floor plan again (the hubs' floor meshes reused), at the walls' top.

    Parameters
    ----------
    scene : SceneBuilder
        The scene, its hubs' floor meshes already made (`add_floors`).
    layout : Layout
        The floor plan.
    """
    top = WALL_HEIGHT + 0.05
    for i in range(len(layout.stretches)):
        s0, s1 = layout.extent(i)
        x, y, heading = along(layout, i, (s0 + s1) / 2, 0.0, 0.0)
        scene.box(
            f"ceiling{i}",
            (x, y, top + 0.05),
            ((s1 - s0) / 2, layout.half_width, 0.05),
            "mat_ceiling",
            yaw=heading,
            collide=False,
            group=names.GROUP_DECOR,
        )
    for owner in layout.junctions:  # the slab's top face is at its origin, 0.1 m thick
        scene.mesh_geom(
            f"hub{owner}_ceiling", f"hub{owner}_mesh", (0, 0, top + 0.1), "mat_ceiling_hub"
        )


def _end_decals(scene: SceneBuilder, layout: Layout) -> None:
    """Add a door on every closed end, a window on the main corridor's."""
    for i in layout.leaves():
        _, s1 = layout.extent(i)
        st = layout.stretches[i]
        u = np.array([np.cos(st.heading), np.sin(st.heading)])
        p = np.asarray(st.start) + (s1 - 0.02) * u
        scene.box(
            f"end{i}_door",
            (p[0], p[1], DOOR_HEIGHT / 2),
            (0.02, 0.8, DOOR_HEIGHT / 2),
            "mat_door",
            yaw=st.heading,
            collide=False,
            group=names.GROUP_DECOR,
        )
    st = layout.stretches[0]
    u = np.array([np.cos(st.heading), np.sin(st.heading)])
    p = np.asarray(st.start) + 0.015 * u
    scene.box(
        "start_window",
        (p[0], p[1], 1.55),
        (0.015, 0.7, 0.65),
        "mat_window",
        yaw=st.heading,
        collide=False,
        group=names.GROUP_DECOR,
    )

"""The outdoor family (``lawn:SEED``): lawns, driveways, paths and sidewalks at junctions.

The areas are joined at bends, T, Y and X junctions, between fences and low stone walls, under
the sun.

Each area wears a look of `OUTDOOR_LOOKS` (its ground and its
boundary) and its furnishing: a garden (trees and bushes), a street (a parked car, a mailbox)
or an orchard (two rows of trees). A building (house, garage or shed) stands behind every
closed end, a fence behind the start. Trees and bushes are trimesh meshes with primitive
colliders, as in the canonical lawn.
"""

from __future__ import annotations

import numpy as np

from scenes import meshes, names, textures
from scenes.appearance import Appearance
from scenes.families.furnish import add_floors, add_walls, along, look_materials
from scenes.families.layout import Layout
from scenes.families.palette import OUTDOOR_LOOKS, draw_looks
from scenes.furnish import place_tree, sky_and_street_materials
from scenes.layout import Rect, add_floor
from scenes.mjcf import SceneBuilder

__all__ = ["build_outdoor"]

FENCE_HEIGHT = 1.2
FENCE_THICKNESS = 0.1
TREE_INSET = 1.1  # m from the boundary: clear of the fence, clear of the routes
APRON = 30.0  # m of grass around the property, for the horizon


def _materials(scene: SceneBuilder, app: Appearance) -> None:
    rng, c = app.texture_rng, app.colour
    for name, img, rep in (
        ("apron", textures.grass(rng, c((0.28, 0.48, 0.18))), 0.5),
        ("facade", textures.window_facade(rng, c((0.88, 0.84, 0.72))), 0.25),
        ("roof", textures.tiles(rng, c((0.45, 0.18, 0.12)), c((0.4, 0.15, 0.1)), n=8), 0.5),
        ("bark", textures.planks(rng, c((0.35, 0.25, 0.15)), n=12), 1.0),
        ("leaves", textures.speckled(rng, c((0.18, 0.42, 0.12)), contrast=0.5), 1.0),
    ):
        scene.texture(f"tex_{name}", img)
        scene.material(f"mat_{name}", f"tex_{name}", texrepeat=(rep, rep), texuniform=True)
    sky_and_street_materials(scene, c)


class _TreePool:
    """A few tree shapes made once per world and planted many times.

    A lumpy crown costs ~15 ms to make, and a world plants up to ~40 trees. Collision is the
    trunk's cylinder.
    """

    def __init__(self, scene: SceneBuilder, rng: np.random.Generator, shapes: int = 4):
        self.scene, self.shapes = scene, []
        for k in range(shapes):
            height, radius = float(rng.uniform(3.5, 6.0)), float(rng.uniform(0.15, 0.28))
            crown = float(rng.uniform(1.2, 2.0))
            scene.mesh(f"tree{k}_trunk_mesh", meshes.trunk(rng, radius, height * 0.75))
            scene.mesh(f"tree{k}_crown_mesh", meshes.canopy(rng, crown))
            self.shapes.append((height, radius, crown))

    def plant(self, name: str, x: float, y: float, k: int) -> None:
        k %= len(self.shapes)
        place_tree(self.scene, name, x, y, self.shapes[k], f"tree{k}", "mat_bark", "mat_leaves")


def _trees_along(trees, layout, i, marks, sides, tag, rng):
    for k, (s, side) in enumerate(zip(marks, sides, strict=True)):
        x, y, _ = along(layout, i, s, side, TREE_INSET)
        trees.plant(f"{tag}_tree{k}", x, y, int(rng.integers(len(trees.shapes))))


def _furnish(
    scene: SceneBuilder,
    layout: Layout,
    i: int,
    kind: str,
    app: Appearance,
    rng: np.random.Generator,
    trees: _TreePool,
) -> None:
    s0, s1 = layout.extent(i)
    shift = app.shift("clutter_shift")
    tag = f"s{i}"
    if kind == "orchard":
        marks = np.arange(s0 + 2.5, s1 - 2.0, rng.uniform(4.0, 5.0)) + shift
        marks = np.repeat(marks[(marks > s0 + 1.5) & (marks < s1 - 1.5)], 2)
        _trees_along(trees, layout, i, marks, [1.0, -1.0] * (len(marks) // 2), tag, rng)
    elif kind == "garden":
        marks = np.sort(rng.uniform(s0 + 2.0, s1 - 2.0, int(rng.integers(2, 5))))
        _trees_along(trees, layout, i, marks, rng.choice([-1.0, 1.0], len(marks)), tag, rng)
    elif kind == "street":
        side = float(rng.choice([-1.0, 1.0]))
        s = float(rng.uniform(s0 + 3.0, max(s0 + 3.0, s1 - 3.0)))
        if layout.half_width >= 3.2:  # room for a car beside the way
            x, y, heading = along(layout, i, s, side, 1.0)
            scene.box(f"{tag}_car_body", (x, y, 0.55), (2.1, 0.9, 0.4), "mat_car", yaw=heading)
            scene.box(
                f"{tag}_car_cabin",
                (x, y, 1.2),
                (1.1, 0.8, 0.3),
                "mat_glass",
                yaw=heading,
                collide=False,
                group=names.GROUP_DECOR,
            )
        x, y, _ = along(layout, i, s + 4.0 if s + 4.0 < s1 - 1.0 else s - 4.0, -side, 0.3)
        scene.cylinder(f"{tag}_mailbox_post", (x, y, 0.6), 0.05, 0.6, "mat_mailbox")
        scene.box(
            f"{tag}_mailbox",
            (x, y, 1.25),
            (0.25, 0.12, 0.12),
            "mat_car",
            collide=False,
            group=names.GROUP_DECOR,
        )


def _building(scene: SceneBuilder, layout: Layout, i: int, rng: np.random.Generator) -> None:
    """Add a house, garage or shed behind the closed end of stretch ``i``."""
    _, s1 = layout.extent(i)
    depth = float(rng.uniform(2.5, 4.5))
    width = min(2 * layout.half_width + 1.0, float(rng.uniform(5.0, 9.0)))
    height = float(rng.uniform(2.2, 3.2))
    x, y, heading = along(layout, i, s1 + FENCE_THICKNESS + 0.3 + depth / 2, 0.0, 0.0)
    scene.box(
        f"s{i}_building",
        (x, y, height / 2),
        (depth / 2, width / 2, height / 2),
        "mat_facade",
        yaw=heading,
    )
    scene.mesh(f"s{i}_roof_mesh", meshes.gable_roof(width + 0.6, depth + 0.6, 1.0 + rng.random()))
    roof = scene.mesh_geom(f"s{i}_roof", f"s{i}_roof_mesh", (x, y, height), "mat_roof")
    roof.set("euler", f"0 0 {heading + np.pi / 2:.6f}")


def build_outdoor(name: str, layout: Layout, app: Appearance, rng: np.random.Generator):
    """Build the scene of an outdoor world: ``(scene, bounds)`` for [`World`][scenes.world.World].

    ``rng`` draws the looks, furnishing and buildings (part of the world, like its layout);
    ``app`` the domain randomisation on top (sun, colours, clutter shift).

    Parameters
    ----------
    name : str
        The world's name (the model's name).
    layout : Layout
        The floor plan.
    app : Appearance
        The appearance draw.
    rng : numpy.random.Generator
        This world's generator of the looks, furnishing and buildings.

    Returns
    -------
    scene : SceneBuilder
        The scene, without the robot.
    bounds : tuple of float
        ``(xmin, xmax, ymin, ymax)`` of the floor plan, m.
    """
    scene = SceneBuilder(name)
    x0, x1, y0, y1 = layout.bounds()
    extent = max(x1 - x0, y1 - y0) + 10.0
    scene.set_visual(
        extent, ((x0 + x1) / 2, (y0 + y1) / 2, 1.0), headlight_ambient=0.35, headlight_diffuse=0.1
    )
    _materials(scene, app)
    looks = draw_looks(layout, OUTDOOR_LOOKS, rng)
    pairs = look_materials(scene, looks, app, rng, floor_repeat=0.5)
    sun_x = -0.4 + 0.3 * app.shift("light_shift")
    scene.light(
        "sun",
        (0.0, 0.0, 30.0),
        direction=(sun_x, 0.3, -1.0),
        directional=True,
        diffuse=app.light((0.85, 0.82, 0.75)),
        specular=(0.3, 0.3, 0.3),
    )
    apron = Rect(x0 - APRON, x1 + APRON, y0 - APRON, y1 + APRON)
    add_floor(scene, "apron_floor", apron, "mat_apron", z=-0.01)
    add_floors(scene, layout, [f for _, f in pairs])
    add_walls(scene, layout, [w for w, _ in pairs], FENCE_HEIGHT, FENCE_THICKNESS, prefix="fence")
    trees = _TreePool(scene, app.texture_rng)
    for i, look in enumerate(looks):
        _furnish(scene, layout, i, look.furnishing, app, rng, trees)
    for i in layout.leaves():
        _building(scene, layout, i, rng)
    return scene, layout.bounds()

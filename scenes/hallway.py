"""The indoor world: a corridor ending in a junction with three exits.

The paper's Fig. 7, rows 1-4. Each branch has its own character, as real corridors do:

- main corridor: beige plaster, blue-grey carpet, wooden doors, posters, white light;
- left: red brick, wooden floor, bookshelves and a bench, warm light;
- straight: blue striped walls, black-and-white tiles, posters and plants, cool light;
- right: bare concrete, green linoleum, grey lockers and fire extinguishers, dim light.

In the ``"hard"`` appearance mode every branch has the main corridor's walls, carpet and white
light; only the furniture, posters and the branches' directions tell them apart.
"""

from __future__ import annotations

import numpy as np

from scenes import names, textures
from scenes.appearance import Appearance
from scenes.furnish import potted_plant, wall_box
from scenes.layout import Rect, add_floor, add_walls
from scenes.mjcf import SceneBuilder
from scenes.regions import ManifoldMap, Region, Route
from scenes.robot import add_robot
from scenes.world import World

CORRIDOR_WIDTH = 2.4
WALL_HEIGHT = 2.6
WALL_THICKNESS = 0.15
MAIN_LENGTH = 16.0
BRANCH_LENGTH = 16.0
ROUTE_START_X = 1.0  # m from the corridor's closed end
ROUTE_END_MARGIN = 0.8  # m short of a branch's end wall
DOOR_WIDTH, DOOR_HEIGHT = 0.9, 2.05

_HW = CORRIDOR_WIDTH / 2.0
_JX = MAIN_LENGTH + _HW  # junction centre x
SEGMENTS = {  # name: (floor rectangle, walled sides)
    "main": (Rect(0.0, MAIN_LENGTH, -_HW, _HW), "nsw"),
    "junction": (Rect(MAIN_LENGTH, MAIN_LENGTH + CORRIDOR_WIDTH, -_HW, _HW), ""),
    "left": (Rect(MAIN_LENGTH, MAIN_LENGTH + CORRIDOR_WIDTH, _HW, _HW + BRANCH_LENGTH), "ewn"),
    "straight": (
        Rect(MAIN_LENGTH + CORRIDOR_WIDTH, MAIN_LENGTH + CORRIDOR_WIDTH + BRANCH_LENGTH, -_HW, _HW),
        "nse",
    ),
    "right": (Rect(MAIN_LENGTH, MAIN_LENGTH + CORRIDOR_WIDTH, -_HW - BRANCH_LENGTH, -_HW), "ews"),
}


def _regions() -> ManifoldMap:
    """Return the manifolds' regions; the junction square is split by its diagonals.

    A robot is on a branch once it has crossed the junction's centre toward that branch.
    """
    x0, x1 = MAIN_LENGTH, MAIN_LENGTH + CORRIDOR_WIDTH
    c = (_JX, 0.0)
    far = x1 + BRANCH_LENGTH
    top, bottom = _HW + BRANCH_LENGTH, -_HW - BRANCH_LENGTH
    poly = {
        "hallway": [(0, -_HW), (x0, -_HW), c, (x0, _HW), (0, _HW)],
        "hallway-left": [(x0, _HW), c, (x1, _HW), (x1, top), (x0, top)],
        "hallway-straight": [(x1, _HW), c, (x1, -_HW), (far, -_HW), (far, _HW)],
        "hallway-right": [(x0, -_HW), (x0, bottom), (x1, bottom), (x1, -_HW), c],
    }
    regions = tuple(Region(k, np.asarray(v, float)) for k, v in poly.items())
    return ManifoldMap(regions, {k: names.MANIFOLD_IDS[k] for k in poly})


def _routes() -> dict[str, Route]:
    start = (ROUTE_START_X, 0.0)
    turn_in = (_JX - 1.0, 0.0)
    end = _HW + BRANCH_LENGTH - ROUTE_END_MARGIN
    far = MAIN_LENGTH + CORRIDOR_WIDTH + BRANCH_LENGTH - ROUTE_END_MARGIN
    pts = {
        "left": [start, turn_in, (_JX, 1.0), (_JX, end)],
        "straight": [start, (far, 0.0)],
        "right": [start, turn_in, (_JX, -1.0), (_JX, -end)],
    }
    return {f"hallway-{b}": Route(f"hallway-{b}", np.asarray(p, float), b) for b, p in pts.items()}


def _materials(scene: SceneBuilder, app: Appearance) -> None:
    rng = app.texture_rng
    c = app.colour
    tex = {
        "main_wall": textures.painted(rng, c((0.86, 0.80, 0.66))),
        "main_floor": textures.speckled(rng, c((0.35, 0.42, 0.55)), contrast=0.25),
        "left_wall": textures.bricks(rng, c((0.62, 0.24, 0.16))),
        "left_floor": textures.planks(rng, c((0.62, 0.42, 0.24))),
        "straight_wall": textures.stripes(rng, c((0.45, 0.62, 0.82)), c((0.15, 0.3, 0.6))),
        "straight_floor": textures.tiles(rng, c((0.92, 0.92, 0.9)), c((0.12, 0.12, 0.14))),
        "right_wall": textures.speckled(rng, c((0.58, 0.58, 0.56)), contrast=0.18),
        "right_floor": textures.speckled(rng, c((0.22, 0.42, 0.3)), contrast=0.15),
        "ceiling": textures.ceiling_tiles(rng),
        "door": textures.panelled_door(rng),
        "end_door": textures.panelled_door(rng, c((0.2, 0.45, 0.25))),
        "shelf": textures.planks(rng, c((0.35, 0.22, 0.12)), n=5),
        "locker": textures.stripes(rng, c((0.55, 0.58, 0.62)), c((0.4, 0.42, 0.46)), period=32),
        "window": textures.window_facade(rng, c((0.9, 0.88, 0.82))),
    }
    for k, img in tex.items():
        scene.texture(f"tex_{k}", img)
    repeat = {
        "left_wall": (0.5, 0.5),
        "_wall": (1.0, 1.0),
        "_floor": (1.0, 1.0),
        "ceiling": (0.5, 0.5),
    }
    for k in tex:
        rep = next((v for s, v in repeat.items() if k.endswith(s)), (1.0, 1.0))
        uniform = k.endswith(("_wall", "_floor")) or k == "ceiling"
        scene.material(f"mat_{k}", f"tex_{k}", texrepeat=rep, texuniform=uniform)
    for i in range(8):
        scene.texture(f"tex_poster{i}", textures.poster(rng))
        scene.material(f"mat_poster{i}", f"tex_poster{i}", texuniform=False)
    scene.material("mat_pot", rgba=c((0.55, 0.3, 0.2)) + (1,))
    scene.material("mat_leaves", rgba=c((0.2, 0.5, 0.2)) + (1,))
    scene.material("mat_red", rgba=(0.8, 0.05, 0.05, 1), specular=0.5, shininess=0.6)
    scene.material("mat_bench", rgba=c((0.3, 0.2, 0.12)) + (1,))


def _furnish(scene: SceneBuilder, app: Appearance) -> None:
    s = app.shift
    main, _ = SEGMENTS["main"]
    left, _ = SEGMENTS["left"]
    straight, _ = SEGMENTS["straight"]
    right, _ = SEGMENTS["right"]
    # Main corridor: offices on both sides, a poster between doors.
    for k, (side, along) in enumerate(
        [("n", 3.0), ("s", 5.5), ("n", 8.5), ("s", 11.0), ("n", 13.5)]
    ):
        wall_box(
            scene,
            f"main_door{k}",
            main,
            side,
            along + s("clutter_shift"),
            DOOR_WIDTH,
            0.04,
            DOOR_HEIGHT,
            "mat_door",
            collide=False,
        )
    for k, (side, along) in enumerate([("s", 2.5), ("n", 6.0), ("s", 8.3), ("n", 11.0)]):
        wall_box(
            scene,
            f"main_poster{k}",
            main,
            side,
            along + s("clutter_shift"),
            0.7,
            0.02,
            0.9,
            f"mat_poster{k}",
            z0=1.2,
            collide=False,
        )
    wall_box(
        scene,
        "main_end_window",
        main,
        "w",
        _HW,
        1.4,
        0.03,
        1.3,
        "mat_window",
        z0=0.9,
        collide=False,
    )
    # Left: library corridor.
    for k, along in enumerate([2.5, 5.0, 7.5, 12.0]):
        wall_box(
            scene,
            f"left_shelf{k}",
            left,
            "w",
            along + s("clutter_shift"),
            1.8,
            0.4,
            2.0,
            "mat_shelf",
        )
    wall_box(scene, "left_bench", left, "e", 9.0 + s("clutter_shift"), 1.6, 0.45, 0.45, "mat_bench")
    wall_box(
        scene,
        "left_end_window",
        left,
        "n",
        _HW,
        1.4,
        0.03,
        1.3,
        "mat_window",
        z0=0.9,
        collide=False,
    )
    # Straight: gallery with posters and plants.
    for k, (side, along) in enumerate([("n", 3.0), ("s", 6.0), ("n", 9.0), ("s", 12.0)]):
        wall_box(
            scene,
            f"straight_poster{k}",
            straight,
            side,
            along + s("clutter_shift"),
            1.0,
            0.02,
            1.2,
            f"mat_poster{k + 4}",
            z0=1.0,
            collide=False,
        )
    for k, (x, y) in enumerate([(straight.x0 + 4.5, 0.8), (straight.x0 + 10.5, -0.8)]):
        potted_plant(
            scene,
            f"straight_plant{k}",
            x + s("clutter_shift"),
            y,
            app.texture_rng,
            "mat_pot",
            "mat_leaves",
        )
    wall_box(
        scene,
        "straight_end_door",
        straight,
        "e",
        _HW,
        1.6,
        0.04,
        DOOR_HEIGHT,
        "mat_end_door",
        collide=False,
    )
    # Right: service corridor.
    for k, along in enumerate([3.0, 3.6, 4.2, 9.5, 10.1]):
        wall_box(
            scene,
            f"right_locker{k}",
            right,
            "e",
            along + s("clutter_shift"),
            0.55,
            0.45,
            1.8,
            "mat_locker",
        )
    for k, along in enumerate([6.5, 13.0]):
        x, y = right.x0 + 0.15, right.y0 + along + s("clutter_shift")
        scene.cylinder(f"right_extinguisher{k}", (x, y, 0.3), 0.09, 0.3, "mat_red")
    wall_box(
        scene,
        "right_end_door",
        right,
        "s",
        _HW,
        1.0,
        0.04,
        DOOR_HEIGHT,
        "mat_end_door",
        collide=False,
    )


def _lights(scene: SceneBuilder, app: Appearance) -> None:
    z = WALL_HEIGHT - 0.05
    d = app.shift("light_shift")
    spots = [
        ("light_main0", (3.5 + d, 0.0), (1.0, 0.98, 0.92)),
        ("light_main1", (8.5 + d, 0.0), (1.0, 0.98, 0.92)),
        ("light_main2", (13.5 + d, 0.0), (1.0, 0.98, 0.92)),
        ("light_left", (_JX, _HW + 8.0 + d), (1.0, 0.8, 0.55)),
        ("light_straight", (MAIN_LENGTH + CORRIDOR_WIDTH + 8.0 + d, 0.0), (0.7, 0.85, 1.0)),
        ("light_right", (_JX, -_HW - 8.0 + d), (0.6, 0.65, 0.6)),
    ]
    for name, (x, y), colour in spots:
        if app.shared_materials:  # a branch's light colour would tell it apart as its paint does
            colour = spots[0][2]
        scene.light(
            name, (x, y, z), diffuse=app.light(colour), attenuation=(0.4, 0.0, 0.04), cutoff=85.0
        )


def build_hallway(app: Appearance) -> World:
    """Build the hallway world from `SEGMENTS` (see the module docstring).

    Parameters
    ----------
    app : Appearance
        The appearance draw: textures, colours, lights and clutter shifts.

    Returns
    -------
    World
        The world with its ground truth.
    """
    scene = SceneBuilder(names.HALLWAY)
    extent = MAIN_LENGTH + CORRIDOR_WIDTH + BRANCH_LENGTH
    scene.set_visual(extent, (extent / 2, 0.0, 1.0), headlight_ambient=0.25, headlight_diffuse=0.15)
    _materials(scene, app)
    ceiling_z = WALL_HEIGHT + 0.05
    for seg, (rect, sides) in SEGMENTS.items():
        # the junction is part of the main corridor's look; in the hard mode every branch is
        style = "main" if seg == "junction" or app.shared_materials else seg
        add_floor(scene, f"{seg}_floor", rect, f"mat_{style}_floor")
        add_floor(scene, f"{seg}_ceiling", rect, "mat_ceiling", z=ceiling_z + 0.05)
        if sides:
            add_walls(
                scene, seg, rect, sides, f"mat_{style}_wall", WALL_HEIGHT + 0.1, WALL_THICKNESS
            )
    _furnish(scene, app)
    _lights(scene, app)
    add_robot(scene)
    x1 = MAIN_LENGTH + CORRIDOR_WIDTH
    bounds = (0.0, x1 + BRANCH_LENGTH, -_HW - BRANCH_LENGTH, _HW + BRANCH_LENGTH)
    return World.from_scene(names.HALLWAY, scene, app, _regions(), bounds, _routes())

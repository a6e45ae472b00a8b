"""Generated worlds: valid by construction over many seeds (floor plans only, no rendering),
built and compiled on a sample, named and refused as documented."""

import itertools
from pathlib import Path

import numpy as np
import pytest
import shapely
from shapely import unary_union
from shapely.geometry import LineString, Point, Polygon

from scenes import build_world
from scenes.families import FAMILY_SPECS, family_layout, parse_world_name
from scenes.families.draw import branch_names, layout_problems
from scenes.families.layout import Layout, Stretch, junction
from scenes.families.splits import (
    REPEATED_TEST_SEEDS,
    SPLITS,
    held_out_worlds,
    split_of,
    split_worlds,
    structure,
)
from scenes.robot import RADIUS
from sim.simulator import compile_world
from sim.teleop import ScriptedTeleop, TeleopConfig

PROPERTY_SEEDS = range(1, 1001)  # per family: every property over 1,000 floor plans
WALL = {"hallway": 0.15, "lawn": 0.1}


def _wall_polygon(wall, thickness):
    centre, half, yaw = wall.box(thickness)
    d = np.array([np.cos(yaw), np.sin(yaw)])
    n = np.array([-d[1], d[0]]) * thickness / 2
    a, b = centre - half * d, centre + half * d
    return Polygon([a - n, b - n, b + n, a + n])


def _check_plan(family: str, layout: Layout) -> None:
    """Every property a floor plan must have, with shapely as the independent referee."""
    name = layout.stretches[0].name
    # pieces meet edge to edge; a micrometre of growth closes the rounding between them
    pieces = [Polygon(p).buffer(1e-6, join_style="mitre") for _, p in layout.pieces()]
    free = unary_union(pieces)
    # the free space is one connected piece
    assert free.geom_type == "Polygon", (name, free.geom_type)
    # the manifold regions partition it: same union, no overlap, every stretch has a region
    regions = [Polygon(r.polygon) for r in layout.regions()]
    assert all(r.is_valid for r in regions), name
    assert abs(sum(r.area for r in regions) - free.area) < 1e-4 * free.area, name
    grown = unary_union([r.buffer(1e-6, join_style="mitre") for r in regions])
    assert grown.symmetric_difference(free).area < 1e-4 * free.area, name
    assert {r.manifold for r in layout.regions()} == {s.name for s in layout.stretches}
    # no wall cuts into the floor (of its own stretch or another)
    walls = [_wall_polygon(w, WALL[family]) for w in layout.walls()]
    cuts = shapely.area(shapely.intersection(walls, free))
    assert cuts.max() < 1e-4, (name, layout.walls()[int(np.argmax(cuts))], cuts.max())
    # each teleop route stays a robot's width plus the driver's wander inside the free space,
    # reaches its leaf's closed end and, together, the routes cross every manifold
    region_polygons = np.array([Polygon(r.polygon) for r in layout.regions()])
    region_names = np.array([r.manifold for r in layout.regions()])
    seen = set()
    for route in layout.routes().values():
        line = LineString(route.waypoints)
        pts = shapely.line_interpolate_point(line, np.arange(0.0, line.length, 0.2))
        clearance = shapely.distance(free.exterior, pts).min()
        assert free.contains(line) and clearance > RADIUS + 0.3, (name, route.name, clearance)
        end = layout.stretches[[s.name for s in layout.stretches].index(route.name)]
        assert Point(route.waypoints[-1]).distance(Point(end.end)) < 2.0
        inside = shapely.covers(region_polygons[:, None], pts[None, :])
        seen.update(region_names[inside.any(axis=1)])
    assert seen == {s.name for s in layout.stretches}, name
    # the stated ranges
    spec = FAMILY_SPECS[family]
    assert spec.width[0] <= 2 * layout.half_width <= spec.width[1]
    assert 2 <= len(layout.stretches) <= spec.max_manifolds
    assert spec.depth[0] <= layout.depth <= spec.depth[1]
    for j in layout.junctions.values():
        assert 2 <= len(j.exits) <= 4 and np.rad2deg(j.gaps.min()) >= spec.min_gap - 1e-6


@pytest.mark.parametrize("family", ["hallway", "lawn"])
def test_floor_plans_are_valid_over_a_thousand_seeds(family):
    kinds, depths, angles = set(), set(), []
    for seed in PROPERTY_SEEDS:
        layout = family_layout(f"{family}:{seed}")
        _check_plan(family, layout)
        kinds.update(len(j.exits) for j in layout.junctions.values())
        depths.add(layout.depth)
        angles += [np.rad2deg(g) for j in layout.junctions.values() for g in j.gaps]
    # the family draws every junction size (bends, T/Y, X) and every depth it states
    assert kinds == {2, 3, 4} and depths == {1, 2, 3}
    # right angles are the exception, not the rule
    assert np.mean(np.abs(np.asarray(angles) % 90.0 - 45.0) > 44.0) < 0.05


@pytest.mark.parametrize("name", ["hallway:1", "hallway:7", "lawn:2", "lawn:8"])
def test_generated_worlds_build_compile_and_keep_their_routes_free(name):
    world = build_world(name)
    again = build_world(name)
    assert world.xml == again.xml and world.assets == again.assets  # a seed is one world
    model = compile_world(world)
    assert model.ntex >= 6 and model.nlight >= 1
    layout = family_layout(name)
    assert world.manifold_names == tuple(s.name for s in layout.stretches)
    assert world.manifold_ids == {s.name: i for i, s in enumerate(layout.stretches)}
    assert set(world.routes) == {layout.stretches[i].name for i in layout.leaves()}
    # the furnishing and trees leave the routes drivable
    free = world.free_space(0.1, inflation=RADIUS)
    for route in world.routes.values():
        line = LineString(route.waypoints)
        pts = np.array([line.interpolate(t).coords[0] for t in np.arange(0, line.length, 0.1)])
        assert free.is_free(pts).all(), route.name
        assert {world.manifolds.name_at(*p) for p in pts} <= set(world.manifold_names)


@pytest.mark.parametrize("name", ["hallway:3", "lawn:4"])
def test_the_scripted_driver_reaches_every_leaf(name):
    """The teleop, driven kinematically (no physics), stays in the free space with the
    robot's radius and reaches the end of every route."""
    world = build_world(name)
    free = world.free_space(0.05, inflation=RADIUS - 0.05)
    dt = 0.1
    for k, route in enumerate(world.routes.values()):
        teleop = ScriptedTeleop(world, route, TeleopConfig(), np.random.default_rng([7, k]))
        pose = teleop.start_pose()
        for _ in range(int(4 * route.length / (0.6 * dt))):
            if teleop.done:
                break
            v, w = teleop.command(pose, dt)
            pose = pose + dt * np.array([v * np.cos(pose[2]), v * np.sin(pose[2]), w])
            assert free.is_free(pose[:2]), (route.name, pose)
        assert teleop.done, (route.name, teleop.progress, teleop.route.length)


def test_hard_mode_shares_the_main_manifolds_materials():
    import xml.etree.ElementTree as ET

    def materials(world, prefix):
        return {
            g.get("material")
            for g in ET.fromstring(world.xml).iter("geom")
            if g.get("name").startswith(prefix)
        }

    default, hard = build_world("hallway:5"), build_world("hallway:5", appearance="hard")
    assert len(materials(hard, "wall")) == 1 < len(materials(default, "wall"))
    assert len(materials(hard, "floor")) == 1 < len(materials(default, "floor"))
    assert hard.footprints == default.footprints and hard.digest == default.digest
    lights = {li.get("diffuse") for li in ET.fromstring(hard.xml).iter("light")}
    assert len(lights) == 1


def test_randomisation_changes_the_look_not_the_plan():
    a = build_world("lawn:6", np.random.default_rng(1))
    b = build_world("lawn:6", np.random.default_rng(2))
    assert a.xml != b.xml and a.digest == b.digest == build_world("lawn:6").digest
    assert build_world("lawn:7").digest != a.digest


def test_the_canonical_worlds_are_seed_zero_of_their_families(worlds):
    for family in ("hallway", "lawn"):
        assert build_world(f"{family}:0").xml == worlds[family].xml
        assert parse_world_name(f"{family}:0") == parse_world_name(family)
        assert split_of(family) == "train"
    with pytest.raises(ValueError, match="canonical world"):
        family_layout("hallway:0")
    assert worlds["hallway"].junctions_between("hallway-left", "hallway-right") == 1
    assert worlds["lawn"].manifold_ids["lawn-right"] == 7  # the paper's ids stay


def test_junction_counts_follow_the_tree():
    world = build_world("hallway:1")
    names = world.manifold_names
    deepest = max(names, key=lambda n: n.count("-"))
    assert world.junctions_between(names[0], names[0]) == 0
    assert world.junctions_between(names[0], deepest) == deepest.count("-")
    with pytest.raises(ValueError, match="manifold must be one of"):
        world.junctions_between(names[0], "kitchen")


def test_a_hub_of_a_right_angled_cross_is_its_square():
    j = junction((0.0, 0.0), [(0, 0.0), (1, np.pi / 2), (2, np.pi), (3, -np.pi / 2)], 1.0)
    np.testing.assert_allclose(j.mouths, 1.0)
    np.testing.assert_allclose(np.abs(j.corners), 1.0)
    poly = Polygon(j.polygon(1.0))
    assert poly.is_valid and poly.area == pytest.approx(4.0)


def test_an_unsound_plan_is_named():
    # two branches that turn back onto the main corridor
    s = (
        Stretch("w", "", None, (0.0, 0.0), 0.0, 12.0),
        Stretch("w-right", "right", 0, (12.0, 0.0), -2.0, 8.0),
        Stretch(
            "w-right-left", "right-left", 1, (12 + 8 * np.cos(-2.0), 8 * np.sin(-2.0)), 2.0, 14.0
        ),
    )
    problems = layout_problems(Layout(s, 1.2), clearance=0.8)
    assert any("apart" in p or "overlaps" in p for p in problems)


def test_branch_names_rank_the_exits_from_right_to_left():
    rad = np.deg2rad
    assert branch_names([rad(-90), rad(5), rad(90)]) == ["right", "straight", "left"]
    assert branch_names([rad(-40), rad(50)]) == ["right", "left"]
    assert branch_names([rad(3), rad(88)]) == ["straight", "left"]
    assert branch_names([rad(30), rad(100)]) == ["right", "left"]
    assert branch_names([rad(-70)]) == ["right"]


def test_splits_are_disjoint_ranges_and_listed_in_order():
    ranges = sorted(SPLITS.values())
    assert all(a[1] < b[0] for a, b in itertools.pairwise(ranges))
    assert split_worlds("lawn", "test", 3) == ["lawn:11000", "lawn:11001", "lawn:11002"]
    assert split_worlds("hallway", "train", 2) == ["hallway:1", "hallway:2"]
    assert split_of("hallway:10999") == "dev" and split_of("hallway:500000") is None
    with pytest.raises(ValueError, match="split must be one of"):
        split_worlds("lawn", "validation")
    with pytest.raises(ValueError, match="count must be"):
        split_worlds("lawn", "dev", 5000)


def test_listed_repeats_copy_a_training_structure_and_are_skipped():
    for family in ("hallway", "lawn"):
        repeats = REPEATED_TEST_SEEDS[family]
        for test_seed, train_seed in list(repeats.items())[:3]:
            a = structure(family_layout(f"{family}:{test_seed}"))
            assert a == structure(family_layout(f"{family}:{train_seed}"))
            assert split_of(f"{family}:{train_seed}") == "train"
        held = held_out_worlds(family, 60)
        assert not {int(n.split(":")[1]) for n in held} & set(repeats)
        assert len(held) == 60 and held == sorted(held, key=lambda n: int(n.split(":")[1]))


def test_held_out_worlds_skip_a_training_structure():
    first = split_worlds("hallway", "test", 2)
    skip = {structure(family_layout(first[0]))}
    assert held_out_worlds("hallway", 2, set()) == first
    assert held_out_worlds("hallway", 2, skip) == [first[1], "hallway:11002"]


@pytest.mark.parametrize(
    "bad", ["maze:3", "hallway:x", "hallway:-2", "hallway:1000000", "Hallway", "lawn:", 7, None]
)
def test_malformed_world_names_name_the_accepted_forms(bad):
    with pytest.raises(ValueError, match="FAMILY:SEED with FAMILY one of"):
        parse_world_name(bad)


def test_the_committed_galleries_show_the_current_generator():
    """The docs' and the report's galleries are committed figures: their first tile must be
    what the generator draws now (``python -m scripts.world_gallery`` redraws them)."""
    import cv2

    from scripts.world_gallery import CAPTION, TILE, world_tile

    for family in ("hallway", "lawn"):
        path = Path(__file__).resolve().parents[2] / "docs" / "img" / f"gallery_{family}.png"
        committed = cv2.cvtColor(cv2.imread(str(path)), cv2.COLOR_BGR2RGB)
        first = committed[: TILE + CAPTION, :TILE]
        # anti-aliased lines and text differ by OpenCV version; a changed plan moves most pixels
        differ = np.any(first != world_tile(f"{family}:1"), axis=-1).mean()
        assert differ < 0.05, (str(path), differ)

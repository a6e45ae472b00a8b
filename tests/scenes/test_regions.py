import numpy as np
import pytest

from scenes.names import MANIFOLD_IDS, NO_MANIFOLD
from scenes.regions import (
    Footprint,
    ManifoldMap,
    Region,
    Route,
    points_in_polygon,
    rasterise_free_space,
)

SQUARE = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
# an L: the square plus a corridor to its right
CORRIDOR = np.array([[2.0, 0.5], [5.0, 0.5], [5.0, 1.5], [2.0, 1.5]])


def test_points_in_a_concave_polygon_by_the_even_odd_rule():
    u = np.array([[0, 0], [3, 0], [3, 3], [2, 3], [2, 1], [1, 1], [1, 3], [0, 3]], float)
    inside = points_in_polygon([[0.5, 2.5], [1.5, 2.5], [2.5, 2.5], [1.5, 0.5], [4, 1]], u)
    np.testing.assert_array_equal(inside, [True, False, True, True, False])


def test_the_first_region_wins_and_off_the_floor_is_no_manifold():
    overlapping = np.array([[1.0, 0.0], [3.0, 0.0], [3.0, 2.0], [1.0, 2.0]])
    ids = {"hallway": MANIFOLD_IDS["hallway"], "hallway-right": MANIFOLD_IDS["hallway-right"]}
    m = ManifoldMap((Region("hallway", SQUARE), Region("hallway-right", overlapping)), ids)
    labels = m.label_at([[0.5, 1.0], [1.5, 1.0], [2.5, 1.0], [9.0, 9.0]])
    hall, right = MANIFOLD_IDS["hallway"], MANIFOLD_IDS["hallway-right"]
    np.testing.assert_array_equal(labels, [hall, hall, right, NO_MANIFOLD])
    assert m.name_at(2.5, 1.0) == "hallway-right" and m.name_at(9, 9) is None
    assert m.label_at(np.zeros((3, 4, 2))).shape == (3, 4)
    with pytest.raises(ValueError, match=r"xy must have shape \(\.\.\., 2\)"):
        m.label_at(np.zeros((4, 3)))
    with pytest.raises(ValueError, match="manifold must be a non-empty name"):
        Region("", SQUARE)


def test_a_box_footprint_grows_with_rounded_corners():
    box = Footprint("crate", (0.0, 0.0), half_size=(1.0, 0.5), yaw=np.pi / 2)
    # rotated a quarter turn: long along y
    assert box.covers(np.array([0.0, 0.9])) and not box.covers(np.array([0.9, 0.0]))
    corner = np.array([0.5, 1.0]) + 0.3 / np.sqrt(2)  # 0.3 m off the corner, diagonally
    assert not box.covers(corner, margin=0.29) and box.covers(corner, margin=0.31)
    disc = Footprint("tree", (1.0, 1.0), radius=0.5)
    np.testing.assert_array_equal(disc.covers(np.array([[1.0, 1.6], [1.0, 1.4]])), [False, True])


def test_free_space_excludes_obstacles_and_inflated_borders():
    m = ManifoldMap((Region("hallway", SQUARE), Region("hallway-right", CORRIDOR)))
    crate = Footprint("crate", (1.0, 1.0), half_size=(0.2, 0.2))
    grid = rasterise_free_space(m, [crate], (0.0, 5.0, 0.0, 2.0), resolution=0.05)
    np.testing.assert_array_equal(
        grid.is_free(np.array([[0.5, 0.5], [1.0, 1.0], [4.0, 1.0], [4.0, 1.8], [-1.0, 1.0]])),
        [True, False, True, False, False],
    )
    inflated = rasterise_free_space(m, [crate], (0.0, 5.0, 0.0, 2.0), 0.05, inflation=0.3)
    # near the crate and near the corridor's walls is no longer free; its centre line is
    np.testing.assert_array_equal(
        inflated.is_free(np.array([[1.0, 1.45], [4.0, 0.7], [4.0, 1.0]])), [False, False, True]
    )
    assert inflated.free.sum() < grid.free.sum()
    # the crate (0.8 m on x) is nearer than any wall
    assert grid.clearance[grid.cell_of(np.array([0.5, 1.0]))] == pytest.approx(0.3, abs=0.03)
    with pytest.raises(ValueError, match="resolution must be > 0"):
        rasterise_free_space(m, [], (0.0, 1.0, 0.0, 1.0), resolution=0.0)


def test_a_route_length_is_its_polyline_length():
    route = Route("main-left", np.array([[0.0, 0.0], [3.0, 0.0], [3.0, 4.0]]), "left")
    assert route.length == pytest.approx(7.0)

"""GeodesicField on a sensed occupancy grid: distances through free space, and a bounded cache."""

import numpy as np
import pytest

from scenes.regions import OccupancyGrid
from servo import geodesic
from servo.geodesic import GeodesicField


def _room_with_wall(width: int = 20) -> OccupancyGrid:
    """A 2 m x 2 m room at 0.1 m with a wall across x = 1 m open only at the top row."""
    free = np.ones((width, width), bool)
    free[:-1, width // 2] = False
    return OccupancyGrid(free=free, origin=(0.0, 0.0), resolution=0.1)


def test_distance_goes_around_the_wall():
    grid = _room_with_wall()
    field = GeodesicField(grid, goal=(1.55, 0.05))
    straight = 1.0  # from (0.55, 0.05), through the wall
    around = field.distance((0.55, 0.05))
    assert around > 3.0 * straight  # up to the gap at the top row and down again
    assert field.distance((1.55, 0.05)) == pytest.approx(0.0)
    path = field.path((0.55, 0.05))
    assert np.all(grid.is_free(path[:-1]))
    assert path[:, 1].max() > 1.85  # passes through the top row


def test_grid_graph_cache_is_bounded_and_reuses_recent_grids():
    grids = [_room_with_wall() for _ in range(geodesic._MAX_GRAPHS + 4)]
    for g in grids:
        GeodesicField(g, goal=(0.05, 0.05))
    assert len(geodesic._GRAPHS) <= geodesic._MAX_GRAPHS
    last = geodesic._grid_graph(grids[-1], 0.1)
    assert geodesic._grid_graph(grids[-1], 0.1)[1] is last[1]  # the same graph, not rebuilt


def test_keep_off_swings_the_path_wide_of_the_wall_and_is_checked():
    grid = _room_with_wall()
    clear = grid.clearance
    tight = GeodesicField(grid, goal=(1.55, 0.05)).path((0.55, 0.05))
    wide = GeodesicField(grid, goal=(1.55, 0.05), keep_off=0.5).path((0.55, 0.05))
    i, j = grid.cell_of(tight[:-1])
    k, m = grid.cell_of(wide[:-1])
    assert clear[k, m].mean() > clear[i, j].mean() + 0.05  # away from the wall's faces
    assert np.all(grid.is_free(wide[:-1]))
    longer = GeodesicField(grid, goal=(1.55, 0.05), keep_off=0.5).distance((0.55, 0.05))
    assert longer > GeodesicField(grid, goal=(1.55, 0.05)).distance((0.55, 0.05))
    with pytest.raises(ValueError, match="keep_off must be a finite number"):
        GeodesicField(grid, goal=(0.05, 0.05), keep_off=-1.0)

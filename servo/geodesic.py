"""Shortest paths through free space: the oracle's route and the SPL's shortest length.

A geodesic distance field from the goal over the occupancy grid (8-connected, obstacles grown
by the robot's radius plus a margin), computed once per goal with Dijkstra.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
from scipy import sparse
from scipy.sparse.csgraph import dijkstra

from scenes import World
from scenes.regions import OccupancyGrid
from scenes.robot import RADIUS

RESOLUTION = 0.1  # m per cell
MARGIN = 0.25  # m beyond the robot's radius: pure pursuit cuts corners
KEEP_OFF_WEIGHT = 4.0  # extra cost per metre driven at no clearance (``keep_off``)


# Recently used grid graphs, newest last. Bounded: every controller's metric map brings its own
# grid, and a worker running hundreds of episodes would otherwise keep every one of them.
_GRAPHS: OrderedDict = OrderedDict()
_MAX_GRAPHS = 8


def _grid_graph(space: World | OccupancyGrid, resolution: float, keep_off: float = 0.0):
    """Return the free cells' 8-connected graph, built once per world or grid.

    It does not depend on goals. A world's free space is its ground truth grown by the robot's
    radius and a margin; a grid (a map's sensed free space) is taken as it is. ``keep_off`` (m):
    see `GeodesicField`.
    """
    key = (id(space), resolution, keep_off)
    if key not in _GRAPHS:
        if isinstance(space, OccupancyGrid):
            grid = space
        else:
            grid = space.free_space(resolution, inflation=RADIUS + MARGIN)
        _GRAPHS[key] = (space, *_build_graph(grid, keep_off))  # holding space keeps its id unique
        while len(_GRAPHS) > _MAX_GRAPHS:
            _GRAPHS.popitem(last=False)
    _GRAPHS.move_to_end(key)
    return _GRAPHS[key][1:]


def _build_graph(grid, keep_off: float = 0.0):
    free = grid.free
    # Edge length times (1 + KEEP_OFF_WEIGHT * shortfall), the shortfall of the cells' clearance
    # below keep_off as a fraction of it: 1 wherever there is room.
    cost = np.ones(free.shape)
    if keep_off > 0:
        cost += KEEP_OFF_WEIGHT * np.clip(1.0 - grid.clearance / keep_off, 0.0, 1.0)
    h, w = free.shape
    ids = np.arange(h * w).reshape(h, w)
    rows, cols, wts = [], [], []
    for di, dj in ((0, 1), (1, 0), (1, 1), (1, -1)):
        # cell (i, j) in slice a, its neighbour (i + di, j + dj) in slice b
        sa = np.s_[max(0, -di) : h - max(0, di), max(0, -dj) : w - max(0, dj)]
        sb = np.s_[max(0, di) : h + min(0, di) or h, max(0, dj) : w + min(0, dj) or w]
        ok = free[sa] & free[sb]
        ia, ib = ids[sa][ok], ids[sb][ok]
        rows += [ia, ib]
        cols += [ib, ia]
        wt = grid.resolution * np.hypot(di, dj) * 0.5 * (cost[sa][ok] + cost[sb][ok])
        wts += [wt, wt]
    graph = sparse.csr_matrix(
        (np.concatenate(wts), (np.concatenate(rows), np.concatenate(cols))), shape=(h * w,) * 2
    )
    return grid, graph


class GeodesicField:
    """Distance (m) from every free cell to ``goal`` (x, y) through free space.

    The free space is a world's (ground truth, for the oracle and SPL) or an ``OccupancyGrid``
    (a map's sensed free space, for a controller; ``resolution`` is then the grid's).

    Parameters
    ----------
    world : World or OccupancyGrid
        The free space.
    goal : array_like
        The goal (x, y, ...); only x and y are read.
    resolution : float, default RESOLUTION
        Metres per cell of a world's grid.
    keep_off : float, default 0.0
        Metres, grids only: cells nearer than this to the grid's edge cost up to
        ``1 + KEEP_OFF_WEIGHT`` times their length, so paths keep to the middle of a passage
        and swing wide round corners (a shortest path hugs a corner, and pure pursuit, which
        cuts inside its path, then scrapes it); distances are then such costs, >= metres.
    """

    def __init__(
        self,
        world: World | OccupancyGrid,
        goal,
        resolution: float = RESOLUTION,
        keep_off: float = 0.0,
    ):
        if isinstance(world, OccupancyGrid):
            resolution = world.resolution
        elif keep_off:
            raise ValueError("keep_off applies to an OccupancyGrid (a sensed map), not a world")
        if not (np.isfinite(keep_off) and keep_off >= 0):
            raise ValueError(f"keep_off must be a finite number of metres >= 0, got {keep_off!r}")
        self.grid, graph = _grid_graph(world, float(resolution), float(keep_off))
        h, w = self.grid.free.shape
        self.goal = np.asarray(goal, np.float64)[:2]
        g = self._nearest_free(self.goal)
        self.distance_grid = dijkstra(graph, indices=g[0] * w + g[1]).reshape(h, w)

    def _nearest_free(self, xy) -> tuple[int, int]:
        i, j = self.grid.cell_of(np.asarray(xy))
        h, w = self.grid.free.shape
        if 0 <= i < h and 0 <= j < w and self.grid.free[i, j]:
            return int(i), int(j)
        free = np.argwhere(self.grid.free)
        k = np.argmin((free[:, 0] - i) ** 2 + (free[:, 1] - j) ** 2)
        return int(free[k, 0]), int(free[k, 1])

    def distance(self, xy) -> float:
        """Return the geodesic distance from ``xy`` to the goal (inf when unreachable).

        Parameters
        ----------
        xy : array_like of shape (2,)
            The point, m.

        Returns
        -------
        float
            The distance, m.
        """
        i, j = self._nearest_free(xy)
        d_cell = np.hypot(*(self.grid.cell_centers()[i, j] - np.asarray(xy)[:2]))
        return float(self.distance_grid[i, j] + d_cell)

    def path(self, xy, max_points: int = 2000) -> np.ndarray:
        """Return the cell centres from ``xy`` down the distance field.

        The path ends with the goal itself when it is reached.

        Parameters
        ----------
        xy : array_like of shape (2,)
            The start, m.
        max_points : int, default 2000
            The most steps taken.

        Returns
        -------
        ndarray of shape (k, 2)
            The path's points.
        """
        i, j = self._nearest_free(xy)
        h, w = self.distance_grid.shape
        centers = self.grid.cell_centers()
        out = [centers[i, j]]
        for _ in range(max_points):
            ii, jj = np.meshgrid(np.arange(i - 1, i + 2), np.arange(j - 1, j + 2), indexing="ij")
            ok = (ii >= 0) & (ii < h) & (jj >= 0) & (jj < w)
            d = np.full(ii.shape, np.inf)
            d[ok] = self.distance_grid[ii[ok], jj[ok]]
            k = np.unravel_index(np.argmin(d), d.shape)
            if d[k] >= self.distance_grid[i, j]:
                out.append(self.goal)
                break
            i, j = int(ii[k]), int(jj[k])
            out.append(centers[i, j])
        return np.asarray(out)

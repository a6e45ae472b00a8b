"""Ground truth on the floor plane: manifold regions and free space.

A world's manifolds are polygons on the floor (the paper's 8 clusters are places, so their
truth is where the robot stands). Free space is an occupancy grid rasterised from the
footprints of every colliding geom, for planning, sampling start poses and tests.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
from scipy import ndimage

from scenes.names import NO_MANIFOLD


def points_in_polygon(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Test many points against one polygon by the even-odd rule, vectorised.

    Vectorised over points and edges. Points exactly on an edge may fall either side; regions
    that share an edge are resolved by their order in `ManifoldMap` (first match wins).

    Parameters
    ----------
    points : array_like of shape (..., 2)
        The points, m.
    polygon : array_like of shape (k, 2)
        The polygon's vertices, m.

    Returns
    -------
    ndarray of shape (N,), bool
        Whether each point (flattened) is inside.
    """
    p = np.asarray(points, np.float64).reshape(-1, 2)
    a = np.asarray(polygon, np.float64)
    b = np.roll(a, -1, axis=0)
    px, py = p[:, 0:1], p[:, 1:2]
    ax, ay, bx, by = a[:, 0], a[:, 1], b[:, 0], b[:, 1]
    straddles = (ay > py) != (by > py)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_cross = ax + (py - ay) * (bx - ax) / (by - ay)
    crosses = straddles & (px < x_cross)
    return (np.count_nonzero(crosses, axis=1) % 2).astype(bool)


@dataclass(frozen=True)
class Region:
    """One manifold's piece of floor: a simple polygon (k, 2) in world metres.

    Parameters
    ----------
    manifold : str
        The manifold's name (non-empty).
    polygon : ndarray of shape (k, 2)
        The polygon's vertices, m.
    """

    manifold: str
    polygon: np.ndarray

    def __post_init__(self):
        """Check that ``manifold`` is a non-empty name."""
        if not isinstance(self.manifold, str) or not self.manifold:
            raise ValueError(f"manifold must be a non-empty name, got {self.manifold!r}")


@dataclass(frozen=True)
class ManifoldMap:
    """The named manifolds of a world as floor regions, queryable at any (x, y).

    Parameters
    ----------
    regions : tuple of Region
        A manifold may own several regions; where regions overlap, the first wins.
    ids : dict of str to int, optional
        The label id of each manifold. Default: their order of first appearance in
        ``regions``, from 0. The canonical worlds pass the paper's ids
        ([`scenes.names.MANIFOLD_IDS`][scenes.names.MANIFOLD_IDS]: the lawn's manifolds are 4 to 7).
    """

    regions: tuple[Region, ...]
    ids: dict = field(default=None, compare=False)

    def __post_init__(self):
        """Fill in the default ``ids``; check they name the manifolds, distinct and >= 0."""
        names = tuple(dict.fromkeys(r.manifold for r in self.regions))
        ids = dict(self.ids) if self.ids is not None else {n: i for i, n in enumerate(names)}
        if set(ids) != set(names):
            raise ValueError(f"ids must name exactly the regions' manifolds {names}, got {ids}")
        values = list(ids.values())
        if any(not isinstance(v, int) or v < 0 for v in values) or len(set(values)) != len(ids):
            raise ValueError(f"ids must be distinct integers >= 0, got {ids}")
        object.__setattr__(self, "ids", ids)

    @property
    def names(self) -> tuple[str, ...]:
        """The manifolds' names, in the order of their ids."""
        return tuple(sorted(self.ids, key=self.ids.get))

    def name_of(self, label: int) -> str | None:
        """Return the name of label id ``label``.

        Parameters
        ----------
        label : int
            A manifold's label id, or [`NO_MANIFOLD`][scenes.names.NO_MANIFOLD].

        Returns
        -------
        str or None
            The manifold's name; None for ``NO_MANIFOLD``.

        Raises
        ------
        ValueError
            When ``label`` is no label id of the map.
        """
        for name, i in self.ids.items():
            if i == label:
                return name
        if label == NO_MANIFOLD:
            return None
        raise ValueError(
            f"label must be one of {sorted(self.ids.values())} or {NO_MANIFOLD}, got {label!r}"
        )

    def label_at(self, xy) -> np.ndarray:
        """Return the manifold ids (`ids`) of points; -1 off every manifold.

        Parameters
        ----------
        xy : array_like of shape (..., 2)
            Points on the floor, m.

        Returns
        -------
        ndarray of shape (...), int64
            The label ids.
        """
        xy = np.asarray(xy, np.float64)
        if xy.shape[-1] != 2:
            raise ValueError(f"xy must have shape (..., 2), got {xy.shape}")
        flat = xy.reshape(-1, 2)
        labels = np.full(len(flat), NO_MANIFOLD, np.int64)
        for region in self.regions:
            todo = labels == NO_MANIFOLD
            if not todo.any():
                break
            inside = points_in_polygon(flat[todo], region.polygon)
            labels[np.flatnonzero(todo)[inside]] = self.ids[region.manifold]
        return labels.reshape(xy.shape[:-1])

    def name_at(self, x: float, y: float) -> str | None:
        """Return the name of the manifold at one point, or None off every manifold.

        Parameters
        ----------
        x, y : float
            The point, m.

        Returns
        -------
        str or None
            The manifold's name.
        """
        return self.name_of(int(self.label_at((x, y))))


@dataclass(frozen=True)
class Footprint:
    """The floor-plane shadow of a colliding geom: an oriented box or a disc.

    Parameters
    ----------
    name : str
        The geom's name.
    center : tuple of float
        (x, y) of its centre, m.
    half_size : tuple of float, default (0.0, 0.0)
        A box's half extents (x, y) before yaw, m.
    yaw : float, default 0.0
        A box's rotation, rad.
    radius : float, default 0.0
        A disc's radius, m (> 0 for a disc).
    """

    name: str
    center: tuple[float, float]
    half_size: tuple[float, float] = (0.0, 0.0)  # box half extents (x, y) before yaw
    yaw: float = 0.0
    radius: float = 0.0  # > 0 for a disc

    def covers(self, xy: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Return whether each point lies within ``margin`` of the footprint.

        Parameters
        ----------
        xy : array_like of shape (..., 2)
            Points on the floor, m.
        margin : float, default 0.0
            Distance the footprint is grown by (rounded at a box's corners), m.

        Returns
        -------
        ndarray of shape (...), bool
            Whether each point is covered.
        """
        d = np.asarray(xy, np.float64) - np.asarray(self.center)
        if self.radius > 0.0:
            return np.hypot(d[..., 0], d[..., 1]) <= self.radius + margin
        c, s = np.cos(self.yaw), np.sin(self.yaw)
        lx = c * d[..., 0] + s * d[..., 1]
        ly = -s * d[..., 0] + c * d[..., 1]
        # Euclidean distance to the box (rounded corners), not a grown square.
        ex = np.maximum(np.abs(lx) - self.half_size[0], 0.0)
        ey = np.maximum(np.abs(ly) - self.half_size[1], 0.0)
        return np.hypot(ex, ey) <= margin


@dataclass(frozen=True)
class OccupancyGrid:
    """Free space on a regular grid.

    ``free[i, j]`` is the cell centred at ``(xmin + (j + 0.5) res, ymin + (i + 0.5) res)``.

    Parameters
    ----------
    free : ndarray of shape (h, w), bool
        Whether each cell is free.
    origin : tuple of float
        ``(xmin, ymin)``, the grid's lower-left corner, m.
    resolution : float
        Cell size ``res``, m.
    """

    free: np.ndarray
    origin: tuple[float, float]
    resolution: float

    def cell_of(self, xy) -> tuple[np.ndarray, np.ndarray]:
        """Return the cell indices of points (possibly off the grid).

        Parameters
        ----------
        xy : array_like of shape (..., 2)
            Points on the floor, m.

        Returns
        -------
        i, j : ndarray of shape (...), int64
            Row (y) and column (x) of each point's cell.
        """
        xy = np.asarray(xy, np.float64)
        j = np.floor((xy[..., 0] - self.origin[0]) / self.resolution).astype(np.int64)
        i = np.floor((xy[..., 1] - self.origin[1]) / self.resolution).astype(np.int64)
        return i, j

    def is_free(self, xy) -> np.ndarray:
        """Return whether each point lies in a free cell (points off the grid are not free).

        Parameters
        ----------
        xy : array_like of shape (..., 2)
            Points on the floor, m.

        Returns
        -------
        ndarray of shape (...), bool
            Whether each point is free.
        """
        i, j = self.cell_of(xy)
        h, w = self.free.shape
        ok = (i >= 0) & (i < h) & (j >= 0) & (j < w)
        out = np.zeros(np.shape(i), bool)
        out[ok] = self.free[i[ok], j[ok]]
        return out

    @cached_property
    def clearance(self) -> np.ndarray:
        """Distance (m) from each cell to the nearest non-free cell."""
        return ndimage.distance_transform_edt(self.free) * self.resolution

    def cell_centers(self) -> np.ndarray:
        """Return the centre of every cell.

        Returns
        -------
        ndarray of shape (h, w, 2)
            (x, y) of each cell's centre, m.
        """
        h, w = self.free.shape
        xs = self.origin[0] + (np.arange(w) + 0.5) * self.resolution
        ys = self.origin[1] + (np.arange(h) + 0.5) * self.resolution
        return np.stack(np.meshgrid(xs, ys), axis=-1)


def rasterise_free_space(
    manifolds: ManifoldMap,
    footprints: list[Footprint],
    bounds: tuple[float, float, float, float],
    resolution: float = 0.05,
    inflation: float = 0.0,
) -> OccupancyGrid:
    """Rasterise free space: cells on a manifold, farther than ``inflation`` from any footprint.

    Parameters
    ----------
    manifolds : ManifoldMap
        The walkable regions.
    footprints : list of Footprint
        The colliding geoms' shadows.
    bounds : tuple of float
        ``(xmin, xmax, ymin, ymax)`` of the grid, m.
    resolution : float, default 0.05
        Cell size, m.
    inflation : float, default 0.0
        Grow obstacles (and the regions' borders) by this much, m (the robot's radius gives
        the configuration space).

    Returns
    -------
    OccupancyGrid
        The free cells.
    """
    if resolution <= 0:
        raise ValueError(f"resolution must be > 0, got {resolution}")
    xmin, xmax, ymin, ymax = bounds
    w = int(np.ceil((xmax - xmin) / resolution))
    h = int(np.ceil((ymax - ymin) / resolution))
    grid = OccupancyGrid(np.ones((h, w), bool), (xmin, ymin), resolution)
    centers = grid.cell_centers()
    free = manifolds.label_at(centers) != NO_MANIFOLD
    for fp in footprints:
        free &= ~fp.covers(centers, margin=inflation)
    if inflation > 0:
        # Region borders are walls too: erode the walkable area by the inflation radius.
        free &= (
            ndimage.distance_transform_edt(manifolds.label_at(centers) != NO_MANIFOLD) * resolution
            > inflation
        )
    return OccupancyGrid(free, (xmin, ymin), resolution)


@dataclass
class Route:
    """A teleop route: the waypoints a sequence follows, main manifold first then a branch.

    Parameters
    ----------
    name : str
        The route's name.
    waypoints : ndarray of shape (k, 2)
        The waypoints, m.
    branch : str
        The branch it takes (``"left"``, ``"straight"``, ``"right"``; in a generated world the
        stretch's branch, or ``"main"``).
    meta : dict, optional
        Further details (a generated world's routes: ``"junctions"``, the junctions passed).
    """

    name: str
    waypoints: np.ndarray
    branch: str
    meta: dict = field(default_factory=dict)

    @property
    def length(self) -> float:
        """The length of the polyline through the waypoints, m."""
        return float(np.sum(np.linalg.norm(np.diff(self.waypoints, axis=0), axis=1)))
